//! The full `ros2msg` definitions of the messages madenet speaks ([`crate::msgs::RosMessage::DEFINITION`],
//! the schemas of a recorded bag: the type's own fields, then each nested type after a line
//! of 80 `=` and `MSG: package/Name`), as the Python `rosbags` package generates them from its
//! ROS 2 Jazzy typestore (`generate_msgdef(name, ros_version=2)`); tests decode bags with them.
//!
//! Each type's fields are written once, in `fields!`; `msgdef!` joins a message's own
//! fields and its nested types, in the order `rosbags` lists them (depth first, each type at
//! its first use).

/// The `ros2msg` fields of a type, one per line.
macro_rules! fields {
    ("builtin_interfaces/Time") => {
        "int32 sec
uint32 nanosec
"
    };
    ("builtin_interfaces/Duration") => {
        "int32 sec
uint32 nanosec
"
    };
    ("std_msgs/Header") => {
        "builtin_interfaces/Time stamp
string frame_id
"
    };
    ("std_msgs/ColorRGBA") => {
        "float32 r
float32 g
float32 b
float32 a
"
    };
    ("std_msgs/Float64") => {
        "float64 data
"
    };
    ("geometry_msgs/Vector3") => {
        "float64 x
float64 y
float64 z
"
    };
    ("geometry_msgs/Point") => {
        "float64 x
float64 y
float64 z
"
    };
    ("geometry_msgs/Quaternion") => {
        "float64 x
float64 y
float64 z
float64 w
"
    };
    ("geometry_msgs/Pose") => {
        "geometry_msgs/Point position
geometry_msgs/Quaternion orientation
"
    };
    ("geometry_msgs/PoseStamped") => {
        "std_msgs/Header header
geometry_msgs/Pose pose
"
    };
    ("geometry_msgs/Transform") => {
        "geometry_msgs/Vector3 translation
geometry_msgs/Quaternion rotation
"
    };
    ("geometry_msgs/TransformStamped") => {
        "std_msgs/Header header
string child_frame_id
geometry_msgs/Transform transform
"
    };
    ("nav_msgs/MapMetaData") => {
        "builtin_interfaces/Time map_load_time
float32 resolution
uint32 width
uint32 height
geometry_msgs/Pose origin
"
    };
    ("sensor_msgs/CompressedImage") => {
        "std_msgs/Header header
string format
uint8[] data
"
    };
    ("visualization_msgs/Marker") => {
        "int32 ARROW=0
int32 CUBE=1
int32 SPHERE=2
int32 CYLINDER=3
int32 LINE_STRIP=4
int32 LINE_LIST=5
int32 CUBE_LIST=6
int32 SPHERE_LIST=7
int32 POINTS=8
int32 TEXT_VIEW_FACING=9
int32 MESH_RESOURCE=10
int32 TRIANGLE_LIST=11
int32 ARROW_STRIP=12
int32 ADD=0
int32 MODIFY=0
int32 DELETE=2
int32 DELETEALL=3
std_msgs/Header header
string ns
int32 id
int32 type
int32 action
geometry_msgs/Pose pose
geometry_msgs/Vector3 scale
std_msgs/ColorRGBA color
builtin_interfaces/Duration lifetime
bool frame_locked
geometry_msgs/Point[] points
std_msgs/ColorRGBA[] colors
string texture_resource
sensor_msgs/CompressedImage texture
visualization_msgs/UVCoordinate[] uv_coordinates
string text
string mesh_resource
visualization_msgs/MeshFile mesh_file
bool mesh_use_embedded_materials
"
    };
    ("visualization_msgs/UVCoordinate") => {
        "float32 u
float32 v
"
    };
    ("visualization_msgs/MeshFile") => {
        "string filename
uint8[] data
"
    };
}

/// A full definition: the message's own fields, then each nested type (`"package/Name"`, see
/// `fields!`) after a line of 80 `=` and `MSG: package/Name`.
macro_rules! msgdef {
    ($own:expr $(, $nested:tt)* $(,)?) => {
        concat!(
            $own,
            $(
                "================================================================================\nMSG: ",
                $nested,
                "\n",
                fields!($nested),
            )*
        )
    };
}

/// `rosgraph_msgs/msg/Clock`.
pub const CLOCK: &str = msgdef!("builtin_interfaces/Time clock\n", "builtin_interfaces/Time");

/// `tf2_msgs/msg/TFMessage`.
pub const TF_MESSAGE: &str = msgdef!(
    "geometry_msgs/TransformStamped[] transforms\n",
    "geometry_msgs/TransformStamped",
    "std_msgs/Header",
    "builtin_interfaces/Time",
    "geometry_msgs/Transform",
    "geometry_msgs/Vector3",
    "geometry_msgs/Quaternion",
);

/// `nav_msgs/msg/OccupancyGrid`.
pub const OCCUPANCY_GRID: &str = msgdef!(
    "std_msgs/Header header
nav_msgs/MapMetaData info
int8[] data
",
    "std_msgs/Header",
    "builtin_interfaces/Time",
    "nav_msgs/MapMetaData",
    "geometry_msgs/Pose",
    "geometry_msgs/Point",
    "geometry_msgs/Quaternion",
);

/// `geometry_msgs/msg/PoseStamped`.
pub const POSE_STAMPED: &str = msgdef!(
    fields!("geometry_msgs/PoseStamped"),
    "std_msgs/Header",
    "builtin_interfaces/Time",
    "geometry_msgs/Pose",
    "geometry_msgs/Point",
    "geometry_msgs/Quaternion",
);

/// `sensor_msgs/msg/LaserScan`.
pub const LASER_SCAN: &str = msgdef!(
    "std_msgs/Header header
float32 angle_min
float32 angle_max
float32 angle_increment
float32 time_increment
float32 scan_time
float32 range_min
float32 range_max
float32[] ranges
float32[] intensities
",
    "std_msgs/Header",
    "builtin_interfaces/Time",
);

/// `nav_msgs/msg/Path`.
pub const PATH: &str = msgdef!(
    "std_msgs/Header header
geometry_msgs/PoseStamped[] poses
",
    "std_msgs/Header",
    "builtin_interfaces/Time",
    "geometry_msgs/PoseStamped",
    "geometry_msgs/Pose",
    "geometry_msgs/Point",
    "geometry_msgs/Quaternion",
);

/// `visualization_msgs/msg/MarkerArray`.
pub const MARKER_ARRAY: &str = msgdef!(
    "visualization_msgs/Marker[] markers\n",
    "visualization_msgs/Marker",
    "std_msgs/Header",
    "builtin_interfaces/Time",
    "geometry_msgs/Pose",
    "geometry_msgs/Point",
    "geometry_msgs/Quaternion",
    "geometry_msgs/Vector3",
    "std_msgs/ColorRGBA",
    "builtin_interfaces/Duration",
    "sensor_msgs/CompressedImage",
    "visualization_msgs/UVCoordinate",
    "visualization_msgs/MeshFile",
);

/// `std_msgs/msg/Float64`.
pub const FLOAT64: &str = msgdef!(fields!("std_msgs/Float64"));
