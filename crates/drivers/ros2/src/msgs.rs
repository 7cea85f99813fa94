//! The ROS 2 messages madenet speaks, as plain structs with their ROS type names and Jazzy
//! type hashes ([`crate::typehash`]), and their CDR encoding (the `cdr-encoding` crate, little
//! endian, after the 4-byte encapsulation header `00 01 00 00`).
//!
//! Field order and types follow the `.msg` definitions of ROS 2 Jazzy (`builtin_interfaces`,
//! `std_msgs`, `geometry_msgs`, `nav_msgs`); CDR has no field names, so order is the format.
//!
//! ```
//! use madenet_ros2::msgs::{PoseStamped, RosMessage};
//!
//! let mut p = PoseStamped::default();
//! p.header.frame_id = "map".into();
//! p.pose.position.x = 1.5;
//! let bytes = p.to_cdr();
//! assert_eq!(&bytes[..4], &[0, 1, 0, 0]); // CDR, little endian
//! assert_eq!(bytes.len(), 4 + 8 + 4 + 4 + 7 * 8); // stamp, "map\0", pose
//! assert_eq!(PoseStamped::from_cdr(&bytes).unwrap(), p);
//! assert_eq!(PoseStamped::dds_type_name(), "geometry_msgs::msg::dds_::PoseStamped_");
//! ```

use serde::{Deserialize, Serialize};

/// The encapsulation header of little-endian plain CDR (what rmw_zenoh and rosbag2 write).
pub const CDR_LE: [u8; 4] = [0, 1, 0, 0];

/// A ROS 2 message type: its names and type hash, and its CDR encoding.
pub trait RosMessage: Serialize + for<'de> Deserialize<'de> {
    /// The ROS type name, e.g. `nav_msgs/msg/OccupancyGrid`.
    const TYPE_NAME: &'static str;
    /// The full `ros2msg` definition, nested types included ([`crate::msgdefs`]).
    const DEFINITION: &'static str;

    /// The type's ROS 2 Jazzy type hash (REP 2011: `RIHS01_` and 64 hex digits), computed
    /// from its type description ([`crate::typehash::jazzy_hash`]: once per process).
    fn type_hash() -> String {
        crate::typehash::jazzy_hash(Self::TYPE_NAME)
    }

    /// The DDS type name rmw_zenoh puts in key expressions, e.g.
    /// `nav_msgs::msg::dds_::OccupancyGrid_`.
    fn dds_type_name() -> String {
        dds_type_name(Self::TYPE_NAME)
    }

    /// The message as CDR bytes: the little-endian encapsulation header, then the fields.
    fn to_cdr(&self) -> Vec<u8> {
        cdr_bytes(self)
    }

    /// [`RosMessage::to_cdr`] into `out` (cleared first), reusing its allocation.
    fn write_cdr(&self, out: &mut Vec<u8>) {
        write_cdr(self, out)
    }

    /// Reads a message from CDR bytes (little or big endian, per the header). Trailing bytes
    /// are refused.
    fn from_cdr(bytes: &[u8]) -> Result<Self, String> {
        read_cdr(bytes)
    }
}

/// The DDS type name of a ROS type name (`pkg/msg/Name` → `pkg::msg::dds_::Name_`), as
/// rmw_zenoh puts it in key expressions; also for services and actions' parts.
///
/// # Panics
/// If `type_name` has no `/` (madenet's own names always have).
pub fn dds_type_name(type_name: &str) -> String {
    let (head, name) = type_name
        .rsplit_once('/')
        .expect("ROS type names are package/msg/Name");
    format!("{}::dds_::{name}_", head.replace('/', "::"))
}

/// Any serializable value (a message, a service request or reply) as CDR bytes:
/// the little-endian encapsulation header, then the fields.
pub fn cdr_bytes<T: Serialize>(value: &T) -> Vec<u8> {
    let mut out = Vec::new();
    write_cdr(value, &mut out);
    out
}

/// [`cdr_bytes`] into `out` (cleared first), reusing its allocation.
pub fn write_cdr<T: Serialize>(value: &T, out: &mut Vec<u8>) {
    out.clear();
    out.extend_from_slice(&CDR_LE);
    cdr_encoding::to_writer::<_, byteorder::LittleEndian, _>(&mut *out, value)
        .expect("every madenet message is CDR-serializable (no maps, no unsized sequences)");
}

/// Reads a value from CDR bytes (little or big endian, per the header). More than 3 bytes
/// after the last field (its padding) are refused.
pub fn read_cdr<T: for<'de> Deserialize<'de>>(bytes: &[u8]) -> Result<T, String> {
    let (header, body) = bytes
        .split_first_chunk::<4>()
        .ok_or_else(|| format!("{} bytes: shorter than the CDR header", bytes.len()))?;
    let (msg, used) = match header[..2] {
        [0, 1] => cdr_encoding::from_bytes::<T, byteorder::LittleEndian>(body),
        [0, 0] => cdr_encoding::from_bytes::<T, byteorder::BigEndian>(body),
        _ => return Err(format!("encapsulation {header:02x?} is not plain CDR")),
    }
    .map_err(|e| e.to_string())?;
    // Up to 3 bytes of padding may follow the last field.
    if body.len() - used > 3 {
        return Err(format!("{} bytes after the message", body.len() - used));
    }
    Ok(msg)
}

/// `builtin_interfaces/msg/Time`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Time {
    /// Seconds since the epoch.
    pub sec: i32,
    /// Nanoseconds within the second.
    pub nanosec: u32,
}

/// `std_msgs/msg/Header`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// When.
    pub stamp: Time,
    /// In which frame (madenet: `map`).
    pub frame_id: String,
}

/// `geometry_msgs/msg/Point`, metres.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Point {
    /// x (m).
    pub x: f64,
    /// y (m).
    pub y: f64,
    /// z (m).
    pub z: f64,
}

/// `geometry_msgs/msg/Quaternion`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

impl Default for Quaternion {
    /// The identity rotation (as in the `.msg` file: `w` defaults to 1).
    fn default() -> Self {
        Quaternion {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 1.0,
        }
    }
}

/// `geometry_msgs/msg/Pose`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Position.
    pub position: Point,
    /// Orientation.
    pub orientation: Quaternion,
}

/// `geometry_msgs/msg/PoseStamped`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseStamped {
    /// Stamp and frame.
    pub header: Header,
    /// The pose.
    pub pose: Pose,
}

/// `nav_msgs/msg/MapMetaData`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MapMetaData {
    /// When the map was loaded.
    pub map_load_time: Time,
    /// Metres per cell.
    pub resolution: f32,
    /// Columns.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// The pose of cell (0, 0)'s corner.
    pub origin: Pose,
}

/// `nav_msgs/msg/OccupancyGrid`: row-major, row 0 at the origin; 0 free, 100 occupied, −1
/// unknown.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct OccupancyGrid {
    /// Stamp and frame.
    pub header: Header,
    /// Size, resolution, origin.
    pub info: MapMetaData,
    /// The cells.
    #[serde(with = "int8_sequence")]
    pub data: Vec<i8>,
}

/// `sensor_msgs/msg/LaserScan`: ranges counter-clockwise from `angle_min` (REP 103: 0 ahead
/// along the sensor frame's x), +∞ where a beam returned nothing within `range_max` (REP 117).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LaserScan {
    /// Stamp (of the first beam) and the sensor's frame.
    pub header: Header,
    /// Angle of the first beam (rad).
    pub angle_min: f32,
    /// Angle of the last beam (rad).
    pub angle_max: f32,
    /// Angle between beams (rad).
    pub angle_increment: f32,
    /// Time between beams (s).
    pub time_increment: f32,
    /// Time between scans (s).
    pub scan_time: f32,
    /// Shortest range measured (m).
    pub range_min: f32,
    /// Longest range measured (m).
    pub range_max: f32,
    /// One range per beam (m).
    pub ranges: Vec<f32>,
    /// One intensity per beam (madenet's lidar has none: empty).
    pub intensities: Vec<f32>,
}

/// `rosgraph_msgs/msg/Clock`: simulated time, for nodes with `use_sim_time`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Clock {
    /// The time.
    pub clock: Time,
}

/// `geometry_msgs/msg/Vector3`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

/// `geometry_msgs/msg/Transform`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Transform {
    /// Translation (m).
    pub translation: Vector3,
    /// Rotation.
    pub rotation: Quaternion,
}

/// `geometry_msgs/msg/TransformStamped`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TransformStamped {
    /// Stamp and parent frame.
    pub header: Header,
    /// The child frame.
    pub child_frame_id: String,
    /// The child frame's pose in the parent's.
    pub transform: Transform,
}

/// `tf2_msgs/msg/TFMessage` (`/tf`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TFMessage {
    /// The transforms.
    pub transforms: Vec<TransformStamped>,
}

/// `nav_msgs/msg/Path`: a planned path.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Path {
    /// Stamp and frame.
    pub header: Header,
    /// The poses along the path, first to last.
    pub poses: Vec<PoseStamped>,
}

/// `std_msgs/msg/ColorRGBA`, each channel 0–1.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ColorRGBA {
    /// Red.
    pub r: f32,
    /// Green.
    pub g: f32,
    /// Blue.
    pub b: f32,
    /// Opacity.
    pub a: f32,
}

/// `builtin_interfaces/msg/Duration`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Duration {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds within the second.
    pub nanosec: u32,
}

/// `sensor_msgs/msg/CompressedImage` (in a [`Marker`]'s texture; madenet leaves it empty).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CompressedImage {
    /// Stamp and frame.
    pub header: Header,
    /// `jpeg` or `png`.
    pub format: String,
    /// The image.
    pub data: Vec<u8>,
}

/// `visualization_msgs/msg/UVCoordinate`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct UVCoordinate {
    /// u.
    pub u: f32,
    /// v.
    pub v: f32,
}

/// `visualization_msgs/msg/MeshFile` (in a [`Marker`]; madenet leaves it empty).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MeshFile {
    /// The file's name.
    pub filename: String,
    /// Its bytes.
    pub data: Vec<u8>,
}

/// `visualization_msgs/msg/Marker` as ROS 2 Jazzy defines it (texture, UV coordinates and
/// mesh file included: CDR has no field names, so a Humble reader needs Humble's definition,
/// which a bag carries).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Marker {
    /// Stamp and frame.
    pub header: Header,
    /// Namespace: with `id`, which marker this one replaces.
    pub ns: String,
    /// Id within the namespace.
    pub id: i32,
    /// Shape: [`Marker::SPHERE`], [`Marker::LINE_LIST`], [`Marker::SPHERE_LIST`], …
    #[serde(rename = "type")]
    pub kind: i32,
    /// [`Marker::ADD`] (also modifies), [`Marker::DELETE`], [`Marker::DELETEALL`].
    pub action: i32,
    /// Pose of the shape (of the points' frame for lists).
    pub pose: Pose,
    /// Size (m; for lines, `x` is the width).
    pub scale: Vector3,
    /// Colour of the whole marker.
    pub color: ColorRGBA,
    /// How long it lives (0: until replaced).
    pub lifetime: Duration,
    /// Whether it moves with its frame.
    pub frame_locked: bool,
    /// Points of list and line shapes.
    pub points: Vec<Point>,
    /// Per-point colours (empty: `color`).
    pub colors: Vec<ColorRGBA>,
    /// Texture resource (unused).
    pub texture_resource: String,
    /// Texture (unused).
    pub texture: CompressedImage,
    /// Texture coordinates (unused).
    pub uv_coordinates: Vec<UVCoordinate>,
    /// Text of [`Marker::TEXT_VIEW_FACING`].
    pub text: String,
    /// Mesh resource (unused).
    pub mesh_resource: String,
    /// Mesh file (unused).
    pub mesh_file: MeshFile,
    /// Whether a mesh brings its own materials (unused).
    pub mesh_use_embedded_materials: bool,
}

impl Marker {
    /// A sphere at `pose`.
    pub const SPHERE: i32 = 2;
    /// Pairs of `points` joined by lines.
    pub const LINE_LIST: i32 = 5;
    /// A sphere at each of `points`.
    pub const SPHERE_LIST: i32 = 7;
    /// `text` facing the viewer.
    pub const TEXT_VIEW_FACING: i32 = 9;
    /// Adds or replaces the marker of this `ns` and `id`.
    pub const ADD: i32 = 0;
    /// Deletes the marker of this `ns` and `id`.
    pub const DELETE: i32 = 2;
    /// Deletes every marker (of this `ns`, when set).
    pub const DELETEALL: i32 = 3;
}

/// `visualization_msgs/msg/MarkerArray`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MarkerArray {
    /// The markers.
    pub markers: Vec<Marker>,
}

/// `std_msgs/msg/Float64`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Float64 {
    /// The value.
    pub data: f64,
}

/// `geometry_msgs/msg/Twist`: linear (m/s) and angular (rad/s) velocity.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Twist {
    /// Linear velocity.
    pub linear: Vector3,
    /// Angular velocity.
    pub angular: Vector3,
}

/// A row-major 6 × 6 covariance (`float64[36]`: the same 36 doubles on the wire).
pub type Covariance = [[f64; 6]; 6];

/// `geometry_msgs/msg/PoseWithCovariance`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovariance {
    /// The pose.
    pub pose: Pose,
    /// Its covariance (x, y, z, roll, pitch, yaw).
    pub covariance: Covariance,
}

/// `geometry_msgs/msg/TwistWithCovariance`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TwistWithCovariance {
    /// The velocity.
    pub twist: Twist,
    /// Its covariance.
    pub covariance: Covariance,
}

/// `nav_msgs/msg/Odometry`: the pose in `header.frame_id` (`odom`), the velocity in
/// `child_frame_id` (`base_link`).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Odometry {
    /// Stamp and the pose's frame.
    pub header: Header,
    /// The velocity's frame.
    pub child_frame_id: String,
    /// The pose.
    pub pose: PoseWithCovariance,
    /// The velocity.
    pub twist: TwistWithCovariance,
}

/// `std_msgs/msg/Bool` (explore_lite's `explore/resume`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Bool {
    /// The value.
    pub data: bool,
}

/// `map_msgs/msg/OccupancyGridUpdate`: a rectangle of new cell values for an
/// [`OccupancyGrid`] published on the same name (costmaps' `*_updates` topics).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct OccupancyGridUpdate {
    /// Stamp and frame (the full grid's).
    pub header: Header,
    /// The rectangle's first column in the full grid.
    pub x: i32,
    /// The rectangle's first row in the full grid (rows from the grid's origin).
    pub y: i32,
    /// Columns in the rectangle.
    pub width: u32,
    /// Rows in the rectangle.
    pub height: u32,
    /// Row-major values (0 free … 100 occupied, −1 unknown), `width × height` of them.
    #[serde(with = "int8_sequence")]
    pub data: Vec<i8>,
}

/// An `int8[]` written as one byte block (the same bytes as a sequence of `int8`, without a
/// serializer call per element).
mod int8_sequence {
    use serde::{Deserializer, Serializer};

    pub fn serialize<S: Serializer>(data: &[i8], s: S) -> Result<S::Ok, S::Error> {
        // i8 and u8 have the same size and layout; CDR writes both as single bytes (no copy).
        s.serialize_bytes(bytemuck::cast_slice(data))
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<i8>, D::Error> {
        let bytes: serde_bytes_buf::ByteBuf = serde::Deserialize::deserialize(d)?;
        Ok(bytes.0.into_iter().map(|b| b as i8).collect())
    }

    /// Receives a byte block (hand-written: `serde_bytes` would be a dependency for 10 lines).
    mod serde_bytes_buf {
        pub struct ByteBuf(pub Vec<u8>);
        impl<'de> serde::Deserialize<'de> for ByteBuf {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                struct V;
                impl serde::de::Visitor<'_> for V {
                    type Value = ByteBuf;
                    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                        f.write_str("an int8 sequence")
                    }
                    fn visit_bytes<E>(self, v: &[u8]) -> Result<ByteBuf, E> {
                        Ok(ByteBuf(v.to_vec()))
                    }
                    fn visit_byte_buf<E>(self, v: Vec<u8>) -> Result<ByteBuf, E> {
                        Ok(ByteBuf(v))
                    }
                }
                d.deserialize_byte_buf(V)
            }
        }
    }
}

impl RosMessage for PoseStamped {
    const TYPE_NAME: &'static str = "geometry_msgs/msg/PoseStamped";
    const DEFINITION: &'static str = crate::msgdefs::POSE_STAMPED;
}

impl RosMessage for OccupancyGrid {
    const TYPE_NAME: &'static str = "nav_msgs/msg/OccupancyGrid";
    const DEFINITION: &'static str = crate::msgdefs::OCCUPANCY_GRID;
}

impl RosMessage for LaserScan {
    const TYPE_NAME: &'static str = "sensor_msgs/msg/LaserScan";
    const DEFINITION: &'static str = crate::msgdefs::LASER_SCAN;
}

impl RosMessage for Clock {
    const TYPE_NAME: &'static str = "rosgraph_msgs/msg/Clock";
    const DEFINITION: &'static str = crate::msgdefs::CLOCK;
}

impl RosMessage for TFMessage {
    const TYPE_NAME: &'static str = "tf2_msgs/msg/TFMessage";
    const DEFINITION: &'static str = crate::msgdefs::TF_MESSAGE;
}

impl RosMessage for Path {
    const TYPE_NAME: &'static str = "nav_msgs/msg/Path";
    const DEFINITION: &'static str = crate::msgdefs::PATH;
}

impl RosMessage for MarkerArray {
    const TYPE_NAME: &'static str = "visualization_msgs/msg/MarkerArray";
    const DEFINITION: &'static str = crate::msgdefs::MARKER_ARRAY;
}

impl RosMessage for Float64 {
    const TYPE_NAME: &'static str = "std_msgs/msg/Float64";
    const DEFINITION: &'static str = crate::msgdefs::FLOAT64;
}

impl RosMessage for Odometry {
    const TYPE_NAME: &'static str = "nav_msgs/msg/Odometry";
    const DEFINITION: &'static str = crate::msgdefs::ODOMETRY;
}

impl RosMessage for Bool {
    const TYPE_NAME: &'static str = "std_msgs/msg/Bool";
    const DEFINITION: &'static str = crate::msgdefs::BOOL;
}

impl RosMessage for OccupancyGridUpdate {
    const TYPE_NAME: &'static str = "map_msgs/msg/OccupancyGridUpdate";
    const DEFINITION: &'static str = crate::msgdefs::OCCUPANCY_GRID_UPDATE;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn type_hashes_are_jazzys() {
        // The hashes madenet used to hard-code: from the ROS 2 Jazzy message definitions,
        // computed independently by the Python `rosbags` package (typestore ROS2_JAZZY,
        // hash_rihs01).
        assert_eq!(
            OccupancyGrid::type_hash(),
            "RIHS01_8d348150c12913a31ee0ec170fbf25089e4745d17035792a1ba94d6f0bc0cfc7"
        );
        assert_eq!(
            PoseStamped::type_hash(),
            "RIHS01_10f3786d7d40fd2b54367835614bff85d4ad3b5dab62bf8bca0cc232d73b4cd8"
        );
        assert_eq!(
            LaserScan::type_hash(),
            "RIHS01_64c191398013af96509d518dac71d5164f9382553fce5c1f8cca5be7924bd828"
        );
        assert_eq!(
            Clock::type_hash(),
            "RIHS01_692f7a66e93a3c83e71765d033b60349ba68023a8c689a79e48078bcb5c58564"
        );
        assert_eq!(
            TFMessage::type_hash(),
            "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087"
        );
        assert_eq!(
            Path::type_hash(),
            "RIHS01_1957a5bb3cee5da65c4e52e52b65a93df227efce4c20f8458b36e73066ca334b"
        );
        assert_eq!(
            MarkerArray::type_hash(),
            "RIHS01_86cb8800b6fb05b5eff1abd7a56f62a5641d3ae9a1c29e78e67e704f1d067dcf"
        );
        assert_eq!(
            Float64::type_hash(),
            "RIHS01_705ba9c3d1a09df43737eb67095534de36fd426c0587779bda2bc51fe790182a"
        );
        assert_eq!(
            OccupancyGrid::dds_type_name(),
            "nav_msgs::msg::dds_::OccupancyGrid_"
        );
    }

    #[test]
    fn cdr_bytes_by_hand() {
        // Header {stamp {1, 2}, "map"}, Pose {(0.5, 0, 0), (0, 0, 0, 1)}: alignment counts
        // from after the encapsulation header, so the f64s start at offset 16 of the body.
        let msg = PoseStamped {
            header: Header {
                stamp: Time { sec: 1, nanosec: 2 },
                frame_id: "map".into(),
            },
            pose: Pose {
                position: Point {
                    x: 0.5,
                    y: 0.0,
                    z: 0.0,
                },
                orientation: Quaternion::default(),
            },
        };
        let b = msg.to_cdr();
        let mut want = vec![
            0, 1, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0, 4, 0, 0, 0, b'm', b'a', b'p', 0,
        ];
        for v in [0.5f64, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0] {
            want.extend(v.to_le_bytes());
        }
        assert_eq!(b, want);
        assert_eq!(PoseStamped::from_cdr(&b).unwrap(), msg);
        // A grid's int8[]: length, then one byte per cell; −1 is 0xff.
        let grid = OccupancyGrid {
            data: vec![-1, 0, 100],
            ..Default::default()
        };
        let b = grid.to_cdr();
        assert_eq!(b[b.len() - 7..], [3, 0, 0, 0, 0xff, 0, 100]);
        assert_eq!(OccupancyGrid::from_cdr(&b).unwrap(), grid);
    }

    #[test]
    fn bad_cdr_is_an_error_not_a_panic() {
        let b = PoseStamped::default().to_cdr();
        assert!(PoseStamped::from_cdr(&b[..b.len() - 1]).is_err());
        assert!(PoseStamped::from_cdr(&[0, 1]).is_err());
        assert!(PoseStamped::from_cdr(&[9, 9, 0, 0]).is_err());
        let mut long = b.clone();
        long.extend([0; 8]);
        assert!(PoseStamped::from_cdr(&long).is_err());
        // A sequence length far beyond the bytes sent allocates nothing.
        let mut g = OccupancyGrid::default().to_cdr();
        let n = g.len();
        g[n - 4..].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(OccupancyGrid::from_cdr(&g).is_err());
    }
}
