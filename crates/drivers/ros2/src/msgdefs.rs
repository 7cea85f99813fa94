//! The full `ros2msg` definitions of the messages madenet speaks ([`crate::msgs::RosMessage::DEFINITION`],
//! the schemas of a recorded bag: the type's own fields, then each nested type after a line
//! of 80 `=` and `MSG: package/Name`), as the Python `rosbags` package generates them from its
//! ROS 2 Jazzy typestore (`generate_msgdef(name, ros_version=2)`); tests decode bags with them.

/// `rosgraph_msgs/msg/Clock`.
pub const CLOCK: &str = r#"builtin_interfaces/Time clock
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"#;

/// `tf2_msgs/msg/TFMessage`.
pub const TF_MESSAGE: &str = r#"geometry_msgs/TransformStamped[] transforms
================================================================================
MSG: geometry_msgs/TransformStamped
std_msgs/Header header
string child_frame_id
geometry_msgs/Transform transform
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
================================================================================
MSG: geometry_msgs/Transform
geometry_msgs/Vector3 translation
geometry_msgs/Quaternion rotation
================================================================================
MSG: geometry_msgs/Vector3
float64 x
float64 y
float64 z
================================================================================
MSG: geometry_msgs/Quaternion
float64 x
float64 y
float64 z
float64 w
"#;

/// `nav_msgs/msg/OccupancyGrid`.
pub const OCCUPANCY_GRID: &str = r#"std_msgs/Header header
nav_msgs/MapMetaData info
int8[] data
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
================================================================================
MSG: nav_msgs/MapMetaData
builtin_interfaces/Time map_load_time
float32 resolution
uint32 width
uint32 height
geometry_msgs/Pose origin
================================================================================
MSG: geometry_msgs/Pose
geometry_msgs/Point position
geometry_msgs/Quaternion orientation
================================================================================
MSG: geometry_msgs/Point
float64 x
float64 y
float64 z
================================================================================
MSG: geometry_msgs/Quaternion
float64 x
float64 y
float64 z
float64 w
"#;

/// `geometry_msgs/msg/PoseStamped`.
pub const POSE_STAMPED: &str = r#"std_msgs/Header header
geometry_msgs/Pose pose
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
================================================================================
MSG: geometry_msgs/Pose
geometry_msgs/Point position
geometry_msgs/Quaternion orientation
================================================================================
MSG: geometry_msgs/Point
float64 x
float64 y
float64 z
================================================================================
MSG: geometry_msgs/Quaternion
float64 x
float64 y
float64 z
float64 w
"#;

/// `sensor_msgs/msg/LaserScan`.
pub const LASER_SCAN: &str = r#"std_msgs/Header header
float32 angle_min
float32 angle_max
float32 angle_increment
float32 time_increment
float32 scan_time
float32 range_min
float32 range_max
float32[] ranges
float32[] intensities
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"#;
