//! The full `ros2msg` definitions of the messages madenet speaks ([`crate::msgs::RosMessage::DEFINITION`],
//! the schemas of a recorded bag: the type's own fields, then each nested type after a line
//! of 80 `=` and `MSG: package/Name`), as the Python `rosbags` package generates them from its
//! ROS 2 Jazzy typestore (`generate_msgdef(name, ros_version=2)`); tests decode bags with them.
//!
//! Each type's fields are written once, in `fields!` (as in the Jazzy `.msg`, `.srv` and
//! `.action` files): `msgdef!` joins a message's own fields and its nested types, in the order
//! `rosbags` lists them (depth first, each type at its first use), and [`jazzy_types`]
//! registers every type for its type hash ([`crate::typehash`]).

use crate::typehash::TypeTable;

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
    ("geometry_msgs/Twist") => {
        "geometry_msgs/Vector3 linear
geometry_msgs/Vector3 angular
"
    };
    ("geometry_msgs/PoseWithCovariance") => {
        "geometry_msgs/Pose pose
float64[36] covariance
"
    };
    ("geometry_msgs/TwistWithCovariance") => {
        "geometry_msgs/Twist twist
float64[36] covariance
"
    };
    ("nav_msgs/Odometry") => {
        "std_msgs/Header header
string child_frame_id
geometry_msgs/PoseWithCovariance pose
geometry_msgs/TwistWithCovariance twist
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
    ("visualization_msgs/MarkerArray") => {
        "visualization_msgs/Marker[] markers
"
    };
    ("rosgraph_msgs/Clock") => {
        "builtin_interfaces/Time clock
"
    };
    ("tf2_msgs/TFMessage") => {
        "geometry_msgs/TransformStamped[] transforms
"
    };
    ("nav_msgs/OccupancyGrid") => {
        "std_msgs/Header header
nav_msgs/MapMetaData info
int8[] data
"
    };
    ("nav_msgs/Path") => {
        "std_msgs/Header header
geometry_msgs/PoseStamped[] poses
"
    };
    ("sensor_msgs/LaserScan") => {
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
"
    };
    ("std_msgs/String") => {
        "string data
"
    };
    ("std_msgs/Bool") => {
        "bool data
"
    };
    ("map_msgs/OccupancyGridUpdate") => {
        "std_msgs/Header header
int32 x
int32 y
uint32 width
uint32 height
int8[] data
"
    };
    ("unique_identifier_msgs/UUID") => {
        "uint8[16] uuid
"
    };
    // As in rcl_interfaces: `char` is `uint8` to rosidl (the rosbags typestore keeps `char`,
    // which changes the hash of every service type).
    ("service_msgs/ServiceEventInfo") => {
        "uint8 REQUEST_SENT=0
uint8 REQUEST_RECEIVED=1
uint8 RESPONSE_SENT=2
uint8 RESPONSE_RECEIVED=3
uint8 event_type
builtin_interfaces/Time stamp
char[16] client_gid
int64 sequence_number
"
    };
    ("action_msgs/GoalInfo") => {
        "unique_identifier_msgs/UUID goal_id
builtin_interfaces/Time stamp
"
    };
    ("action_msgs/GoalStatus") => {
        "int8 STATUS_UNKNOWN=0
int8 STATUS_ACCEPTED=1
int8 STATUS_EXECUTING=2
int8 STATUS_CANCELING=3
int8 STATUS_SUCCEEDED=4
int8 STATUS_CANCELED=5
int8 STATUS_ABORTED=6
action_msgs/GoalInfo goal_info
int8 status
"
    };
    ("action_msgs/GoalStatusArray") => {
        "action_msgs/GoalStatus[] status_list
"
    };
    ("action_msgs/srv/CancelGoal_Request") => {
        "action_msgs/GoalInfo goal_info
"
    };
    ("action_msgs/srv/CancelGoal_Response") => {
        "int8 ERROR_NONE=0
int8 ERROR_REJECTED=1
int8 ERROR_UNKNOWN_GOAL_ID=2
int8 ERROR_GOAL_TERMINATED=3
int8 return_code
action_msgs/GoalInfo[] goals_canceling
"
    };
    ("example_interfaces/srv/AddTwoInts_Request") => {
        "int64 a
int64 b
"
    };
    ("example_interfaces/srv/AddTwoInts_Response") => {
        "int64 sum
"
    };
    ("example_interfaces/action/Fibonacci_Goal") => {
        "int32 order
"
    };
    ("example_interfaces/action/Fibonacci_Result") => {
        "int32[] sequence
"
    };
    ("example_interfaces/action/Fibonacci_Feedback") => {
        "int32[] sequence
"
    };
    // nav2_msgs (navigation2, branch jazzy).
    ("nav2_msgs/action/NavigateToPose_Goal") => {
        "geometry_msgs/PoseStamped pose
string behavior_tree
"
    };
    ("nav2_msgs/action/NavigateToPose_Result") => {
        "uint16 NONE=0
uint16 UNKNOWN=9000
uint16 FAILED_TO_LOAD_BEHAVIOR_TREE=9001
uint16 TF_ERROR=9002
uint16 error_code
string error_msg
"
    };
    ("nav2_msgs/action/NavigateToPose_Feedback") => {
        "geometry_msgs/PoseStamped current_pose
builtin_interfaces/Duration navigation_time
builtin_interfaces/Duration estimated_time_remaining
int16 number_of_recoveries
float32 distance_remaining
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
pub const CLOCK: &str = msgdef!(fields!("rosgraph_msgs/Clock"), "builtin_interfaces/Time");

/// `tf2_msgs/msg/TFMessage`.
pub const TF_MESSAGE: &str = msgdef!(
    fields!("tf2_msgs/TFMessage"),
    "geometry_msgs/TransformStamped",
    "std_msgs/Header",
    "builtin_interfaces/Time",
    "geometry_msgs/Transform",
    "geometry_msgs/Vector3",
    "geometry_msgs/Quaternion",
);

/// `nav_msgs/msg/OccupancyGrid`.
pub const OCCUPANCY_GRID: &str = msgdef!(
    fields!("nav_msgs/OccupancyGrid"),
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
    fields!("sensor_msgs/LaserScan"),
    "std_msgs/Header",
    "builtin_interfaces/Time",
);

/// `nav_msgs/msg/Path`.
pub const PATH: &str = msgdef!(
    fields!("nav_msgs/Path"),
    "std_msgs/Header",
    "builtin_interfaces/Time",
    "geometry_msgs/PoseStamped",
    "geometry_msgs/Pose",
    "geometry_msgs/Point",
    "geometry_msgs/Quaternion",
);

/// `visualization_msgs/msg/MarkerArray`.
pub const MARKER_ARRAY: &str = msgdef!(
    fields!("visualization_msgs/MarkerArray"),
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

/// `nav_msgs/msg/Odometry`.
pub const ODOMETRY: &str = msgdef!(
    fields!("nav_msgs/Odometry"),
    "std_msgs/Header",
    "builtin_interfaces/Time",
    "geometry_msgs/PoseWithCovariance",
    "geometry_msgs/Pose",
    "geometry_msgs/Point",
    "geometry_msgs/Quaternion",
    "geometry_msgs/TwistWithCovariance",
    "geometry_msgs/Twist",
    "geometry_msgs/Vector3",
);

/// `std_msgs/msg/Bool`.
pub const BOOL: &str = msgdef!(fields!("std_msgs/Bool"));

/// `map_msgs/msg/OccupancyGridUpdate`.
pub const OCCUPANCY_GRID_UPDATE: &str = msgdef!(
    fields!("map_msgs/OccupancyGridUpdate"),
    "std_msgs/Header",
    "builtin_interfaces/Time",
);

/// `action_msgs/msg/GoalStatusArray`.
pub const GOAL_STATUS_ARRAY: &str = msgdef!(
    fields!("action_msgs/GoalStatusArray"),
    "action_msgs/GoalStatus",
    "action_msgs/GoalInfo",
    "unique_identifier_msgs/UUID",
    "builtin_interfaces/Time",
);

/// Registers in `t` every ROS 2 Jazzy type madenet speaks, from the fields above: the messages
/// of its topics and bags and the types they use, `std_msgs/msg/String` and `Bool`,
/// `map_msgs/msg/OccupancyGridUpdate`, the types of ROS 2 services and actions
/// (`service_msgs`, `unique_identifier_msgs`, `action_msgs` with its service `CancelGoal`),
/// `example_interfaces/srv/AddTwoInts`, `example_interfaces/action/Fibonacci` and
/// `nav2_msgs/action/NavigateToPose`, with the types derived from each service and action.
///
/// # Panics
/// If a definition here does not read as `.msg` text, or clashes with one already in `t` (a
/// programming error; the tests register them all).
pub fn jazzy_types(t: &mut TypeTable) {
    fn ok(r: Result<(), String>) {
        if let Err(e) = r {
            panic!("madenet's Jazzy type definitions: {e}");
        }
    }
    // `pkg/Name` (the `fields!` key of a message) is `pkg/msg/Name`.
    macro_rules! messages {
        ($($name:tt),* $(,)?) => {$(
            let (pkg, name) = $name.split_once('/').expect("fields! keys are pkg/Name");
            ok(t.add_message(&format!("{pkg}/msg/{name}"), fields!($name)));
        )*};
    }
    messages!(
        "builtin_interfaces/Time",
        "builtin_interfaces/Duration",
        "std_msgs/Header",
        "std_msgs/ColorRGBA",
        "std_msgs/Float64",
        "std_msgs/String",
        "std_msgs/Bool",
        "geometry_msgs/Vector3",
        "geometry_msgs/Point",
        "geometry_msgs/Quaternion",
        "geometry_msgs/Pose",
        "geometry_msgs/PoseStamped",
        "geometry_msgs/Transform",
        "geometry_msgs/TransformStamped",
        "nav_msgs/MapMetaData",
        "nav_msgs/OccupancyGrid",
        "nav_msgs/Path",
        "geometry_msgs/Twist",
        "geometry_msgs/PoseWithCovariance",
        "geometry_msgs/TwistWithCovariance",
        "nav_msgs/Odometry",
        "map_msgs/OccupancyGridUpdate",
        "sensor_msgs/LaserScan",
        "sensor_msgs/CompressedImage",
        "visualization_msgs/Marker",
        "visualization_msgs/MarkerArray",
        "visualization_msgs/UVCoordinate",
        "visualization_msgs/MeshFile",
        "rosgraph_msgs/Clock",
        "tf2_msgs/TFMessage",
        "unique_identifier_msgs/UUID",
        "service_msgs/ServiceEventInfo",
        "action_msgs/GoalInfo",
        "action_msgs/GoalStatus",
        "action_msgs/GoalStatusArray",
    );
    ok(t.add_service(
        "action_msgs/srv/CancelGoal",
        fields!("action_msgs/srv/CancelGoal_Request"),
        fields!("action_msgs/srv/CancelGoal_Response"),
    ));
    ok(t.add_service(
        "example_interfaces/srv/AddTwoInts",
        fields!("example_interfaces/srv/AddTwoInts_Request"),
        fields!("example_interfaces/srv/AddTwoInts_Response"),
    ));
    ok(t.add_action(
        "example_interfaces/action/Fibonacci",
        fields!("example_interfaces/action/Fibonacci_Goal"),
        fields!("example_interfaces/action/Fibonacci_Result"),
        fields!("example_interfaces/action/Fibonacci_Feedback"),
    ));
    ok(t.add_action(
        "nav2_msgs/action/NavigateToPose",
        fields!("nav2_msgs/action/NavigateToPose_Goal"),
        fields!("nav2_msgs/action/NavigateToPose_Result"),
        fields!("nav2_msgs/action/NavigateToPose_Feedback"),
    ));
}
