//! ROS 2 type hashes (RIHS01, REP 2011) computed from type descriptions, as `rosidl` computes
//! them when it builds an interface package.
//!
//! Since Iron, every ROS 2 message, service and action type has a *type hash*: `RIHS01_` and
//! 64 lowercase hex digits. rmw_zenoh puts it in every key expression and liveliness token, so
//! a publisher, subscription, client or server with the wrong hash is invisible to ROS 2 nodes
//! of the right one; rosbag2 records it per topic. The hash is computed as follows:
//!
//! 1. each type is a list of fields, each with a name and a field type (`type_id`,
//!    `capacity`, `string_capacity`, `nested_type_name`; constants and default values are no
//!    part of it), as in `type_description_interfaces`;
//! 2. the type and every type it references, transitively (sorted by name, each once), are
//!    written as one compact JSON document in a fixed key order;
//! 3. the hash is the SHA-256 of that text.
//!
//! A [`TypeTable`] holds the types, read from `.msg` text ([`TypeTable::add_message`]);
//! services and actions get the derived types `rosidl` makes for them (request, response and
//! event; goal, result, feedback, the two services and the feedback message). [`jazzy_hash`]
//! gives the hash of any type madenet speaks, from its ROS 2 Jazzy definitions
//! ([`crate::msgdefs::jazzy_types`]).
//!
//! The algorithm and layout follow `rosidl_generator_type_description` (ROS 2 Jazzy): its
//! hashable representation is Python's `json.dumps` with `separators=(', ', ': ')`,
//! `ensure_ascii=True` and insertion-ordered keys, after the default values are removed.
//!
//! ```
//! use madenet_ros2::typehash::TypeTable;
//!
//! let mut t = TypeTable::new();
//! t.add_message("std_msgs/msg/String", "string data\n").unwrap();
//! assert_eq!(
//!     t.rihs01("std_msgs/msg/String").unwrap(),
//!     "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
//! );
//! ```

use sha2::{Digest, Sha256};
use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::sync::OnceLock;

/// `FieldType.type_id` of a nested (message) type; the other ids are in [`basic_type_id`].
pub const NESTED_TYPE: u8 = 1;
/// Added to a field's value type id for a fixed-size array `T[N]`.
pub const ARRAY: u8 = 48;
/// Added to a field's value type id for a bounded sequence `T[<=N]`.
pub const BOUNDED_SEQUENCE: u8 = 96;
/// Added to a field's value type id for an unbounded sequence `T[]`.
pub const UNBOUNDED_SEQUENCE: u8 = 144;

/// The field `rosidl` gives a message that has none (an IDL struct needs a member).
pub const EMPTY_PLACEHOLDER: &str = "structure_needs_at_least_one_member";

/// The type of one field, as `type_description_interfaces/msg/FieldType`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FieldType {
    /// The value type's id ([`NESTED_TYPE`] or [`basic_type_id`]), plus [`ARRAY`],
    /// [`BOUNDED_SEQUENCE`] or [`UNBOUNDED_SEQUENCE`] for an array or sequence.
    pub type_id: u8,
    /// The array's size or the bounded sequence's bound; 0 otherwise.
    pub capacity: u64,
    /// The bound of a bounded string (`string<=N`); 0 otherwise.
    pub string_capacity: u64,
    /// The nested type's full name (`pkg/msg/Name`); empty for basic types.
    pub nested_type_name: String,
}

impl FieldType {
    /// A single (not array) nested type `name` (`pkg/msg/Name`).
    pub fn nested(name: &str) -> Self {
        FieldType {
            type_id: NESTED_TYPE,
            capacity: 0,
            string_capacity: 0,
            nested_type_name: name.to_string(),
        }
    }
}

/// One field of a type: its name and type.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Field {
    /// The field name.
    pub name: String,
    /// Its type.
    pub field_type: FieldType,
}

impl Field {
    /// A field `name` of type `field_type`.
    pub fn new(name: &str, field_type: FieldType) -> Self {
        Field {
            name: name.to_string(),
            field_type,
        }
    }
}

/// The `FieldType.type_id` of `.msg` basic type `name` (`int32`, `string`, …; `bounded`: a
/// bounded `string<=N` or `wstring<=N`), with `rosidl_adapter`'s `.msg` to IDL mapping: `char`
/// is `uint8`, `byte` is `octet` (16). `None` for a name that is not a basic type.
pub fn basic_type_id(name: &str, bounded: bool) -> Option<u8> {
    Some(match (name, bounded) {
        ("int8", false) => 2,
        ("uint8" | "char", false) => 3,
        ("int16", false) => 4,
        ("uint16", false) => 5,
        ("int32", false) => 6,
        ("uint32", false) => 7,
        ("int64", false) => 8,
        ("uint64", false) => 9,
        ("float32", false) => 10,
        ("float64", false) => 11,
        ("bool", false) => 15,
        ("byte", false) => 16,
        ("string", false) => 17,
        ("wstring", false) => 18,
        ("string", true) => 21,
        ("wstring", true) => 22,
        _ => return None,
    })
}

/// Type descriptions by full type name (`pkg/msg/Name`, `pkg/srv/Name_Request`,
/// `pkg/action/Name_Goal`, …), and their RIHS01 hashes.
#[derive(Clone, Debug, Default)]
pub struct TypeTable {
    types: BTreeMap<String, Vec<Field>>,
}

impl TypeTable {
    /// An empty table.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds type `name` (`pkg/<kind>/Name`) with `fields`; none gives it the placeholder
    /// field `uint8 structure_needs_at_least_one_member`, as `rosidl` does. Adding a type
    /// again with the same fields does nothing; with other fields it is an error.
    pub fn add_fields(&mut self, name: &str, mut fields: Vec<Field>) -> Result<(), String> {
        split_name(name)?;
        if fields.is_empty() {
            fields.push(Field::new(
                EMPTY_PLACEHOLDER,
                FieldType {
                    type_id: 3,
                    capacity: 0,
                    string_capacity: 0,
                    nested_type_name: String::new(),
                },
            ));
        }
        match self.types.get(name) {
            Some(old) if *old == fields => Ok(()),
            Some(_) => Err(format!("{name}: added twice, with different fields")),
            None => {
                self.types.insert(name.to_string(), fields);
                Ok(())
            }
        }
    }

    /// Adds message `name` (`pkg/msg/Name`) from its `.msg` text: one field a line (`float64
    /// x`, `geometry_msgs/Pose pose`, `uint8[] data`, `int32[3] a`, `int32[<=3] b`,
    /// `string<=10 s`, with or without a default value); constants (`int32 ARROW=0`),
    /// comments (`#` to the end of the line) and blank lines are skipped. A nested type
    /// `pkg/Name` is `pkg/msg/Name`; a bare `Name` is in `name`'s own package, but a bare
    /// `Header` is `std_msgs/msg/Header`.
    pub fn add_message(&mut self, name: &str, fields: &str) -> Result<(), String> {
        let (pkg, _, _) = split_name(name)?;
        let parsed = parse_fields(pkg, fields).map_err(|e| format!("{name}: {e}"))?;
        self.add_fields(name, parsed)
    }

    /// Adds service `name` (`pkg/srv/Name`) from the `.msg` text of its request and response,
    /// with the types `rosidl` derives: `Name_Request`, `Name_Response`, `Name_Event`
    /// (`service_msgs/msg/ServiceEventInfo info`, `Name_Request[<=1] request`,
    /// `Name_Response[<=1] response`), and the service type itself (`request_message`,
    /// `response_message`, `event_message`).
    pub fn add_service(&mut self, name: &str, request: &str, response: &str) -> Result<(), String> {
        let (pkg, _, _) = split_name(name)?;
        let parse = |part, text| parse_fields(pkg, text).map_err(|e| format!("{name}_{part}: {e}"));
        let (req, resp) = (parse("Request", request)?, parse("Response", response)?);
        self.add_service_fields(name, req, resp)
    }

    /// [`TypeTable::add_service`] from the request's and response's fields.
    pub fn add_service_fields(
        &mut self,
        name: &str,
        request: Vec<Field>,
        response: Vec<Field>,
    ) -> Result<(), String> {
        let (req, resp, event) = (
            format!("{name}_Request"),
            format!("{name}_Response"),
            format!("{name}_Event"),
        );
        self.add_fields(&req, request)?;
        self.add_fields(&resp, response)?;
        let at_most_one = |t: &str| FieldType {
            type_id: NESTED_TYPE + BOUNDED_SEQUENCE,
            capacity: 1,
            string_capacity: 0,
            nested_type_name: t.to_string(),
        };
        self.add_fields(
            &event,
            vec![
                Field::new(
                    "info",
                    FieldType::nested("service_msgs/msg/ServiceEventInfo"),
                ),
                Field::new("request", at_most_one(&req)),
                Field::new("response", at_most_one(&resp)),
            ],
        )?;
        self.add_fields(
            name,
            vec![
                Field::new("request_message", FieldType::nested(&req)),
                Field::new("response_message", FieldType::nested(&resp)),
                Field::new("event_message", FieldType::nested(&event)),
            ],
        )
    }

    /// Adds action `name` (`pkg/action/Name`) from the `.msg` text of its goal, result and
    /// feedback, with the types `rosidl` derives: `Name_Goal`, `Name_Result`,
    /// `Name_Feedback`; the services `Name_SendGoal` (`unique_identifier_msgs/msg/UUID
    /// goal_id`, `Name_Goal goal` → `bool accepted`, `builtin_interfaces/msg/Time stamp`) and
    /// `Name_GetResult` (`goal_id` → `int8 status`, `Name_Result result`); the message
    /// `Name_FeedbackMessage` (`goal_id`, `Name_Feedback feedback`); and the action type
    /// itself (`goal`, `result`, `feedback`, `send_goal_service`, `get_result_service`,
    /// `feedback_message`).
    pub fn add_action(
        &mut self,
        name: &str,
        goal: &str,
        result: &str,
        feedback: &str,
    ) -> Result<(), String> {
        let (pkg, _, _) = split_name(name)?;
        let [goal_t, result_t, feedback_t, send_goal, get_result, feedback_msg] = [
            "Goal",
            "Result",
            "Feedback",
            "SendGoal",
            "GetResult",
            "FeedbackMessage",
        ]
        .map(|part| format!("{name}_{part}"));
        for (t, text) in [
            (&goal_t, goal),
            (&result_t, result),
            (&feedback_t, feedback),
        ] {
            let fields = parse_fields(pkg, text).map_err(|e| format!("{t}: {e}"))?;
            self.add_fields(t, fields)?;
        }
        let goal_id = || {
            Field::new(
                "goal_id",
                FieldType::nested("unique_identifier_msgs/msg/UUID"),
            )
        };
        let basic = |id| FieldType {
            type_id: id,
            capacity: 0,
            string_capacity: 0,
            nested_type_name: String::new(),
        };
        self.add_service_fields(
            &send_goal,
            vec![goal_id(), Field::new("goal", FieldType::nested(&goal_t))],
            vec![
                Field::new("accepted", basic(15)),
                Field::new("stamp", FieldType::nested("builtin_interfaces/msg/Time")),
            ],
        )?;
        self.add_service_fields(
            &get_result,
            vec![goal_id()],
            vec![
                Field::new("status", basic(2)),
                Field::new("result", FieldType::nested(&result_t)),
            ],
        )?;
        self.add_fields(
            &feedback_msg,
            vec![
                goal_id(),
                Field::new("feedback", FieldType::nested(&feedback_t)),
            ],
        )?;
        self.add_fields(
            name,
            vec![
                Field::new("goal", FieldType::nested(&goal_t)),
                Field::new("result", FieldType::nested(&result_t)),
                Field::new("feedback", FieldType::nested(&feedback_t)),
                Field::new("send_goal_service", FieldType::nested(&send_goal)),
                Field::new("get_result_service", FieldType::nested(&get_result)),
                Field::new("feedback_message", FieldType::nested(&feedback_msg)),
            ],
        )
    }

    /// The full names of the types in the table, sorted.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.types.keys().map(String::as_str)
    }

    /// The fields of type `name`, if it is in the table.
    pub fn fields(&self, name: &str) -> Option<&[Field]> {
        self.types.get(name).map(Vec::as_slice)
    }

    /// The text that is hashed for type `name`: its description and those of all the types
    /// it references, transitively (sorted by name, each once), as the JSON that
    /// `rosidl_generator_type_description` hashes. A type missing from the table is an error
    /// naming it.
    pub fn hashable_json(&self, name: &str) -> Result<String, String> {
        let own = self
            .types
            .get(name)
            .ok_or_else(|| format!("unknown type {name}"))?;
        // Every type reachable from `name`'s fields (`name` itself only if it were reachable).
        let mut referenced = BTreeSet::new();
        let mut queue: Vec<(&str, &str)> = nested(own).map(|t| (t, name)).collect();
        while let Some((t, by)) = queue.pop() {
            if referenced.insert(t) {
                let fields = self
                    .types
                    .get(t)
                    .ok_or_else(|| format!("{name}: unknown type {t} (a field of {by})"))?;
                queue.extend(nested(fields).map(|n| (n, t)));
            }
        }
        let mut out = String::with_capacity(256 * (1 + referenced.len()));
        out.push_str("{\"type_description\": ");
        write_type(&mut out, name, own);
        out.push_str(", \"referenced_type_descriptions\": [");
        for (i, t) in referenced.iter().enumerate() {
            if i > 0 {
                out.push_str(", ");
            }
            write_type(&mut out, t, &self.types[*t]);
        }
        out.push_str("]}");
        Ok(out)
    }

    /// The RIHS01 hash of type `name`: `RIHS01_` and the SHA-256, in lowercase hex, of
    /// [`TypeTable::hashable_json`]. A type missing from the table (`name` or one it
    /// references) is an error naming it.
    pub fn rihs01(&self, name: &str) -> Result<String, String> {
        let digest = Sha256::digest(self.hashable_json(name)?.as_bytes());
        let mut out = String::with_capacity(7 + 64);
        out.push_str("RIHS01_");
        for b in digest {
            write!(out, "{b:02x}").expect("writing to a String cannot fail");
        }
        Ok(out)
    }
}

/// The types madenet speaks (ROS 2 Jazzy, [`crate::msgdefs::jazzy_types`]) and their hashes,
/// computed once.
fn jazzy() -> &'static (TypeTable, BTreeMap<String, String>) {
    static JAZZY: OnceLock<(TypeTable, BTreeMap<String, String>)> = OnceLock::new();
    JAZZY.get_or_init(|| {
        let mut t = TypeTable::new();
        crate::msgdefs::jazzy_types(&mut t);
        let hashes = t
            .names()
            .map(|n| {
                let h = t
                    .rihs01(n)
                    .unwrap_or_else(|e| panic!("madenet's Jazzy types are incomplete: {e}"));
                (n.to_string(), h)
            })
            .collect();
        (t, hashes)
    })
}

/// The table of the ROS 2 Jazzy types madenet speaks ([`crate::msgdefs::jazzy_types`]).
pub fn jazzy_types() -> &'static TypeTable {
    &jazzy().0
}

/// The RIHS01 hash of `name` (`pkg/msg/Name`, `pkg/srv/Name`, `pkg/action/Name`, or a type
/// derived from a service or action, e.g. `pkg/action/Name_SendGoal`), one of the ROS 2
/// Jazzy types madenet registers ([`crate::msgdefs::jazzy_types`]). Computed once per
/// process.
///
/// # Panics
/// If madenet never registered `name` (a programming error: madenet only sends and
/// receives its own types), naming it; [`TypeTable::rihs01`] is the fallible form.
pub fn jazzy_hash(name: &str) -> String {
    jazzy()
        .1
        .get(name)
        .unwrap_or_else(|| {
            panic!("{name} is not one of madenet's ROS 2 Jazzy types (msgdefs::jazzy_types)")
        })
        .clone()
}

/// `pkg/<kind>/Name` as its three parts, or an error.
fn split_name(name: &str) -> Result<(&str, &str, &str), String> {
    let mut parts = name.split('/');
    match (parts.next(), parts.next(), parts.next(), parts.next()) {
        (Some(pkg), Some(kind), Some(n), None) if [pkg, kind, n].iter().all(|p| !p.is_empty()) => {
            Ok((pkg, kind, n))
        }
        _ => Err(format!(
            "{name:?} is not a type name pkg/<msg|srv|action>/Name"
        )),
    }
}

/// The nested type names among `fields`.
fn nested(fields: &[Field]) -> impl Iterator<Item = &str> {
    fields
        .iter()
        .map(|f| f.field_type.nested_type_name.as_str())
        .filter(|n| !n.is_empty())
}

/// The fields of `.msg` text in package `pkg`, as `rosidl_adapter` reads them: tabs are
/// spaces, a `#` starts a comment, the first word is the type, and a line whose rest has a
/// `=` is a constant.
fn parse_fields(pkg: &str, text: &str) -> Result<Vec<Field>, String> {
    let mut fields = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = raw.replace('\t', " ");
        let line = line.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let (ty, rest) = line.split_once(' ').unwrap_or((line, ""));
        let rest = rest.trim_start();
        if rest.contains('=') {
            continue; // a constant: not part of the type description
        }
        let name = rest.split(' ').next().unwrap_or("");
        if name.is_empty() {
            return Err(format!("line {}: {raw:?} has no field name", i + 1));
        }
        let field_type =
            parse_type(pkg, ty).map_err(|e| format!("line {}: {raw:?}: {e}", i + 1))?;
        fields.push(Field::new(name, field_type));
    }
    Ok(fields)
}

/// A `.msg` field type (`int32`, `string<=10`, `pkg/Name[<=3]`, …) of a type in `pkg`.
fn parse_type(pkg: &str, ty: &str) -> Result<FieldType, String> {
    let size = |s: &str| match s.parse::<u64>() {
        Ok(n) if n > 0 => Ok(n),
        _ => Err(format!("{s:?} is not a size > 0")),
    };
    let (value, suffix, capacity) = match ty.strip_suffix(']') {
        None => (ty, 0, 0),
        Some(t) => {
            let (value, bound) = t.rsplit_once('[').ok_or("`]` without `[`")?;
            match bound {
                "" => (value, UNBOUNDED_SEQUENCE, 0),
                b => match b.strip_prefix("<=") {
                    Some(b) => (value, BOUNDED_SEQUENCE, size(b)?),
                    None => (value, ARRAY, size(b)?),
                },
            }
        }
    };
    let (base, string_capacity) = match value.split_once("<=") {
        Some((s @ ("string" | "wstring"), bound)) => (s, size(bound)?),
        Some(_) => return Err(format!("{value:?}: only strings have a bound")),
        None => (value, 0),
    };
    let (id, nested_type_name) = match basic_type_id(base, string_capacity > 0) {
        Some(id) => (id, String::new()),
        None => (NESTED_TYPE, nested_name(pkg, base)?),
    };
    Ok(FieldType {
        type_id: id + suffix,
        capacity,
        string_capacity,
        nested_type_name,
    })
}

/// The full name of nested type `ty` used in package `pkg`: `a/B` is `a/msg/B`, `a/msg/B`
/// stays, a bare `Header` is `std_msgs/msg/Header` and another bare `B` is `pkg/msg/B`.
fn nested_name(pkg: &str, ty: &str) -> Result<String, String> {
    let ok = |s: &str| {
        !s.is_empty()
            && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
            && !s.starts_with(|c: char| c.is_ascii_digit())
    };
    let parts: Vec<&str> = ty.split('/').collect();
    let full = match parts[..] {
        ["Header"] => "std_msgs/msg/Header".to_string(),
        [n] => format!("{pkg}/msg/{n}"),
        [p, n] => format!("{p}/msg/{n}"),
        [_, _, _] => ty.to_string(),
        _ => String::new(),
    };
    if full.split('/').all(ok) && !full.is_empty() {
        Ok(full)
    } else {
        Err(format!("{ty:?} is neither a basic type nor a type name"))
    }
}

/// Appends one `IndividualTypeDescription` to `out`, in `rosidl`'s key order.
fn write_type(out: &mut String, name: &str, fields: &[Field]) {
    out.push_str("{\"type_name\": ");
    json_string(out, name);
    out.push_str(", \"fields\": [");
    for (i, f) in fields.iter().enumerate() {
        if i > 0 {
            out.push_str(", ");
        }
        let t = &f.field_type;
        out.push_str("{\"name\": ");
        json_string(out, &f.name);
        write!(
            out,
            ", \"type\": {{\"type_id\": {}, \"capacity\": {}, \"string_capacity\": {}, \
             \"nested_type_name\": ",
            t.type_id, t.capacity, t.string_capacity
        )
        .expect("writing to a String cannot fail");
        json_string(out, &t.nested_type_name);
        out.push_str("}}");
    }
    out.push_str("]}");
}

/// Appends `s` as a JSON string, as Python's `json.dumps(..., ensure_ascii=True)` writes it.
fn json_string(out: &mut String, s: &str) {
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            '\u{8}' => out.push_str("\\b"),
            '\u{c}' => out.push_str("\\f"),
            ' '..='~' => out.push(c),
            _ => {
                let mut units = [0u16; 2];
                for u in c.encode_utf16(&mut units) {
                    write!(out, "\\u{u:04x}").expect("writing to a String cannot fail");
                }
            }
        }
    }
    out.push('"');
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rmw_zenoh_design_examples() {
        // docs/design.md of ros2/rmw_zenoh: the `chatter` topic and the `add_two_ints` service.
        assert_eq!(
            jazzy_hash("std_msgs/msg/String"),
            "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
        );
        assert_eq!(
            jazzy_hash("example_interfaces/srv/AddTwoInts"),
            "RIHS01_e118de6bf5eeb66a2491b5bda11202e7b68f198d6f67922cf30364858239c81a"
        );
    }

    #[test]
    fn every_registered_type_hashes() {
        let t = jazzy_types();
        assert!(t.names().count() > 60);
        for n in t.names() {
            assert!(jazzy_hash(n).starts_with("RIHS01_"), "{n}");
        }
    }

    #[test]
    fn hashable_json_is_rosidls_layout() {
        let mut t = TypeTable::new();
        t.add_message(
            "p/msg/A",
            "int32[3] a\nstring<=10[<=2] s\np/B[] b # comment\n",
        )
        .unwrap();
        t.add_message("p/msg/B", "").unwrap();
        assert_eq!(
            t.hashable_json("p/msg/A").unwrap(),
            "{\"type_description\": {\"type_name\": \"p/msg/A\", \"fields\": [\
             {\"name\": \"a\", \"type\": {\"type_id\": 54, \"capacity\": 3, \
             \"string_capacity\": 0, \"nested_type_name\": \"\"}}, \
             {\"name\": \"s\", \"type\": {\"type_id\": 117, \"capacity\": 2, \
             \"string_capacity\": 10, \"nested_type_name\": \"\"}}, \
             {\"name\": \"b\", \"type\": {\"type_id\": 145, \"capacity\": 0, \
             \"string_capacity\": 0, \"nested_type_name\": \"p/msg/B\"}}]}, \
             \"referenced_type_descriptions\": [{\"type_name\": \"p/msg/B\", \"fields\": [\
             {\"name\": \"structure_needs_at_least_one_member\", \"type\": {\"type_id\": 3, \
             \"capacity\": 0, \"string_capacity\": 0, \"nested_type_name\": \"\"}}]}]}"
        );
    }

    #[test]
    fn independently_computed_hashes() {
        // Computed by the Python `rosbags` package (0.11.9, typestore ROS2_JAZZY,
        // `Typestore.hash_rihs01`), with the service and action types registered from their
        // Jazzy `.msg` text and ServiceEventInfo's `client_gid` corrected to `uint8[16]`
        // (rosidl reads `char` as `uint8`; the typestore keeps `char`):
        // the helpers of interop/rihs01.py. The action types themselves: rosbags over a message
        // with the action's six fields. Each service's and action's derived types and all the
        // messages registered agree with rosbags too.
        for (name, hash) in [
            (
                "example_interfaces/action/Fibonacci_SendGoal",
                "RIHS01_d1a57fb2a4afe8c21e34fb10db206f16ce6729b28531141472df92277c55b557",
            ),
            (
                "example_interfaces/action/Fibonacci_GetResult",
                "RIHS01_1b0de0d5d29dc955d92f546706568428632771db13ec84c15ec1c1a59f424a57",
            ),
            (
                "example_interfaces/action/Fibonacci_FeedbackMessage",
                "RIHS01_c1de71afd52e49a89c53d8262366884185bc0a02f78ce051c4e46b0a7fe59bb2",
            ),
            (
                "example_interfaces/action/Fibonacci",
                "RIHS01_9508051da1ea4658de144b09bd0690ff3de52104683d847aed764d2915906f51",
            ),
            (
                "action_msgs/srv/CancelGoal",
                "RIHS01_573d8b0a534451d7bc2ac8c5ffde8ac14b8593b7001175d0cd6516dcbeb8689a",
            ),
            (
                "action_msgs/msg/GoalStatusArray",
                "RIHS01_6c1684b00f177d37438febe6e709fc4e2b0d4248dca4854946f9ed8b30cda83e",
            ),
            (
                "unique_identifier_msgs/msg/UUID",
                "RIHS01_1b8e8aca958cbea28fe6ef60bf6c19b683c97a9ef60bb34752067d0f2f7ab437",
            ),
            (
                "map_msgs/msg/OccupancyGridUpdate",
                "RIHS01_c4095b0be2e4363f8978a1570e0293ee093436f1e1c61d99b48502ac317025e8",
            ),
            (
                "nav2_msgs/action/NavigateToPose_SendGoal",
                "RIHS01_a4fcb3bee1bf32e21a0e541a943b221aa0826996e2c98f079b47022b256f48b5",
            ),
            (
                "nav2_msgs/action/NavigateToPose_GetResult",
                "RIHS01_c407920357d566771e8882b4ef4d1f1a84ee922d609920ccd57faa6d6e391dc5",
            ),
            (
                "nav2_msgs/action/NavigateToPose_FeedbackMessage",
                "RIHS01_9d1f6fa2eb975ce733b419ac2e97b134d8ff92b6478b6559feed9a50bdfd82b3",
            ),
            (
                "nav2_msgs/action/NavigateToPose",
                "RIHS01_a56dba8a3234a1215e610180dc703ae25bbf406dded8b54887891c9732857eab",
            ),
            (
                "std_msgs/msg/Bool",
                "RIHS01_feb91e995ff9ebd09c0cb3d2aed18b11077585839fb5db80193b62d74528f6c9",
            ),
        ] {
            assert_eq!(jazzy_hash(name), hash, "{name}");
        }
    }

    #[test]
    fn unknown_nested_type_is_an_error_naming_it() {
        let mut t = TypeTable::new();
        t.add_message("p/msg/A", "p/Missing m\n").unwrap();
        let e = t.rihs01("p/msg/A").unwrap_err();
        assert!(e.contains("p/msg/Missing"), "{e}");
        assert!(t.rihs01("p/msg/Nope").unwrap_err().contains("p/msg/Nope"));
        // Deeper down too.
        t.add_message("p/msg/B", "p/A[<=3] a\n").unwrap();
        assert!(t.rihs01("p/msg/B").unwrap_err().contains("p/msg/Missing"));
    }

    #[test]
    fn constants_and_defaults_are_not_hashed() {
        let mut t = TypeTable::new();
        t.add_message("p/msg/A", "int32 x\n").unwrap();
        t.add_message("p/msg/B", "int32 X=1\nint8 Y = -2 # why\nint32 x 5\n")
            .unwrap();
        let hash = |t: &TypeTable, n| {
            let j = t.hashable_json(n).unwrap();
            j.replacen(n, "p/msg/A", 1)
        };
        assert_eq!(hash(&t, "p/msg/B"), hash(&t, "p/msg/A"));
        // And so the same hash under one name.
        let mut u = TypeTable::new();
        u.add_message("p/msg/A", "int32 X=1\nint32 x\n").unwrap();
        assert_eq!(u.rihs01("p/msg/A"), t.rihs01("p/msg/A"));
    }

    #[test]
    fn char_is_uint8_and_placeholders() {
        let mut t = TypeTable::new();
        t.add_message("p/msg/C", "char[16] g\n").unwrap();
        t.add_message("p/msg/U", "uint8[16] g\n").unwrap();
        assert_eq!(t.fields("p/msg/C"), t.fields("p/msg/U"));
        t.add_service("p/srv/S", "", "").unwrap();
        assert_eq!(
            t.fields("p/srv/S_Request").unwrap()[0].name,
            EMPTY_PLACEHOLDER
        );
        let event: Vec<_> = t
            .fields("p/srv/S_Event")
            .unwrap()
            .iter()
            .map(|f| &f.name)
            .collect();
        assert_eq!(event, ["info", "request", "response"]);
    }

    #[test]
    fn bad_text_and_conflicts_are_errors() {
        let mut t = TypeTable::new();
        assert!(t.add_message("p/msg/A", "int32[0] a\n").is_err());
        assert!(t.add_message("p/msg/A", "int32[x] a\n").is_err());
        assert!(t.add_message("p/msg/A", "int32<=3 a\n").is_err());
        assert!(t.add_message("p/msg/A", "int32\n").is_err());
        assert!(t.add_message("p/msg/A", "a/b/c/D d\n").is_err());
        assert!(t.add_message("A", "int32 a\n").is_err());
        t.add_message("p/msg/A", "int32 a\n").unwrap();
        t.add_message("p/msg/A", "int32 a\n").unwrap();
        assert!(t.add_message("p/msg/A", "int64 a\n").is_err());
    }

    #[test]
    fn json_strings_are_pythons() {
        let mut s = String::new();
        json_string(&mut s, "a\"\\\n\u{1}é😀");
        assert_eq!(s, "\"a\\\"\\\\\\n\\u0001\\u00e9\\ud83d\\ude00\"");
    }
}
