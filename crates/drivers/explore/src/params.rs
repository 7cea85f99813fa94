//! explore_lite's parameter file, read as a ROS 2 node reads `--params-file FILE`.
//!
//! The file is a ROS 2 parameter YAML: node sections, each holding `ros__parameters:`. A
//! section's name is its keys down to `ros__parameters`, joined by `/`, with a leading `/`
//! (`explore_node:` is `/explore_node`; `robot0: explore_node:` and `/robot0/explore_node:` are
//! `/robot0/explore_node`), as rcl's YAML parser names them. Of those, as rclcpp applies them,
//! the wildcard section `/**` applies to every node and the section named exactly the node's
//! fully qualified name after it (its values win); no other section applies — rclcpp
//! implements no further wildcard matching, so neither does this. Sections for other nodes are
//! skipped. When none applies, that is an error here (ROS would silently run on defaults).
//!
//! Parameters (explore_lite's, with its defaults; then madenet's):
//!
//! | name | type | default | meaning |
//! | --- | --- | --- | --- |
//! | `robot_base_frame` | string | `base_link` | the robot's frame in TF |
//! | `costmap_topic` | string | `costmap` | the map (or costmap) to explore |
//! | `costmap_updates_topic` | string | `costmap_updates` | its updates |
//! | `visualize` | bool | false | publish the frontiers as markers |
//! | `planner_frequency` | double | 1.0 | decisions per second (> 0) |
//! | `progress_timeout` | double | 30.0 | seconds without progress before a goal is given up |
//! | `potential_scale` | double | 0.001 | weight of a frontier's distance |
//! | `orientation_scale` | double | 0.0 | read, unused (as explore_lite) |
//! | `gain_scale` | double | 1.0 | weight of a frontier's size |
//! | `transform_tolerance` | double | 0.3 | seconds a TF lookup may be old |
//! | `min_frontier_size` | double | 0.5 | metres; smaller frontiers are ignored |
//! | `return_to_init` | bool | false | go back to the start when done |
//! | `policy` | string | `explore-lite` | madenet: the policy choosing goals (`explore-lite`, or one of madenet's: `spread`, `made-net-any`, …) |
//! | `decision_frequency` | double | 2.0 | madenet: checks per second whether a madenet policy's macro action ended (the paper's agents decide when it ends, not on a clock); `explore-lite` plans at `planner_frequency` |
//! | `teammates` | string array | `[]` | madenet: the teammates' namespaces (`/robot1`, …) |
//! | `use_sim_time` | bool | false | ROS's own: follow `/clock` |
//!
//! As rclcpp, a double parameter given as an integer (`planner_frequency: 1`) is a type error
//! (write `1.0`); a parameter not in the table is an error naming it.

use serde::de::{self, Deserialize, Deserializer, MapAccess, SeqAccess, Visitor};
use std::fmt;
use std::path::Path;

/// What went wrong with a parameter file.
#[derive(Debug, thiserror::Error)]
pub enum ParamsError {
    /// The file could not be read.
    #[error("{file}: {source}")]
    Read {
        /// The file.
        file: String,
        /// Why.
        source: std::io::Error,
    },
    /// Not a ROS 2 parameter file.
    #[error("{file}: {why}")]
    Format {
        /// The file.
        file: String,
        /// Why.
        why: String,
    },
    /// A parameter of the node's sections is unknown or has a bad value.
    #[error("{file}: section {section}: parameter {name}: {why}")]
    Parameter {
        /// The file.
        file: String,
        /// The section it is in (`/**`, `/robot0/explore_node`).
        section: String,
        /// The parameter.
        name: String,
        /// Why.
        why: String,
    },
    /// No section of the file applies to the node.
    #[error("{file}: no section applies to node {node} (rclcpp applies `/**` and the node's exact name; the file has {sections})")]
    NoSection {
        /// The file.
        file: String,
        /// The node's fully qualified name.
        node: String,
        /// The file's section names.
        sections: String,
    },
}

/// explore_lite's parameters and madenet's own ([module docs](self)).
#[derive(Clone, Debug, PartialEq)]
pub struct ExploreParams {
    /// The robot's frame in TF.
    pub robot_base_frame: String,
    /// The map (or costmap) topic.
    pub costmap_topic: String,
    /// Its updates topic.
    pub costmap_updates_topic: String,
    /// Publish frontiers as markers.
    pub visualize: bool,
    /// Decisions per second.
    pub planner_frequency: f64,
    /// Seconds without progress before a goal is given up.
    pub progress_timeout: f64,
    /// Weight of a frontier's distance in its cost.
    pub potential_scale: f64,
    /// Read and kept; explore_lite does not use it.
    pub orientation_scale: f64,
    /// Weight of a frontier's size in its cost.
    pub gain_scale: f64,
    /// Seconds a TF lookup may be old.
    pub transform_tolerance: f64,
    /// Metres; frontiers shorter than this are ignored.
    pub min_frontier_size: f64,
    /// Return to the start when exploration is done.
    pub return_to_init: bool,
    /// madenet: the policy that chooses goals.
    pub policy: String,
    /// madenet: the teammates' namespaces.
    pub teammates: Vec<String>,
    /// madenet: checks per second whether a madenet policy's macro action ended
    /// (`explore-lite` plans at `planner_frequency`).
    pub decision_frequency: f64,
    /// ROS's own: follow `/clock` (simulated time) instead of the wall clock.
    pub use_sim_time: bool,
}

impl Default for ExploreParams {
    /// explore_lite's declared defaults (`explore.cpp`, `costmap_client.cpp`), the
    /// `explore-lite` policy and no teammates.
    fn default() -> Self {
        ExploreParams {
            robot_base_frame: "base_link".into(),
            costmap_topic: "costmap".into(),
            costmap_updates_topic: "costmap_updates".into(),
            visualize: false,
            planner_frequency: 1.0,
            progress_timeout: 30.0,
            potential_scale: 1e-3,
            orientation_scale: 0.0,
            gain_scale: 1.0,
            transform_tolerance: 0.3,
            min_frontier_size: 0.5,
            return_to_init: false,
            policy: "explore-lite".into(),
            teammates: Vec::new(),
            decision_frequency: 2.0,
            use_sim_time: false,
        }
    }
}

/// A YAML value with mappings in file order (serde's untagged enums and maps would not keep
/// it, and sections apply in order).
#[derive(Clone, Debug, PartialEq)]
enum Value {
    Null,
    Bool(bool),
    Int(i64),
    Float(f64),
    Str(String),
    List(Vec<Value>),
    Map(Vec<(String, Value)>),
}

impl Value {
    fn kind(&self) -> &'static str {
        match self {
            Value::Null => "null",
            Value::Bool(_) => "a bool",
            Value::Int(_) => "an integer",
            Value::Float(_) => "a double",
            Value::Str(_) => "a string",
            Value::List(_) => "a list",
            Value::Map(_) => "a mapping",
        }
    }
}

impl<'de> Deserialize<'de> for Value {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Value;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a YAML value")
            }
            fn visit_unit<E>(self) -> Result<Value, E> {
                Ok(Value::Null)
            }
            fn visit_none<E>(self) -> Result<Value, E> {
                Ok(Value::Null)
            }
            fn visit_bool<E>(self, b: bool) -> Result<Value, E> {
                Ok(Value::Bool(b))
            }
            fn visit_i64<E>(self, i: i64) -> Result<Value, E> {
                Ok(Value::Int(i))
            }
            fn visit_u64<E: de::Error>(self, u: u64) -> Result<Value, E> {
                i64::try_from(u)
                    .map(Value::Int)
                    .map_err(|_| E::custom(format!("{u} does not fit a ROS integer (int64)")))
            }
            fn visit_f64<E>(self, f: f64) -> Result<Value, E> {
                Ok(Value::Float(f))
            }
            fn visit_str<E>(self, s: &str) -> Result<Value, E> {
                Ok(Value::Str(s.to_string()))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Value, A::Error> {
                let mut out = Vec::new();
                while let Some(v) = seq.next_element()? {
                    out.push(v);
                }
                Ok(Value::List(out))
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Value, A::Error> {
                let mut out = Vec::new();
                while let Some((k, v)) = map.next_entry::<String, Value>()? {
                    out.push((k, v));
                }
                Ok(Value::Map(out))
            }
        }
        d.deserialize_any(V)
    }
}

/// The file's node sections in file order: (name, its parameters flattened to dotted names).
type Sections = Vec<(String, Vec<(String, Value)>)>;

/// Walks `map` (keys so far: `path`) down to each `ros__parameters`.
fn collect(map: &[(String, Value)], path: &str, out: &mut Sections) -> Result<(), String> {
    for (key, value) in map {
        if key == "ros__parameters" {
            let Value::Map(params) = value else {
                return Err(format!(
                    "{path}: ros__parameters is {}, not a mapping",
                    value.kind()
                ));
            };
            let mut flat = Vec::new();
            flatten(params, "", &mut flat);
            let name = if path.is_empty() {
                "/".to_string()
            } else {
                path.to_string()
            };
            out.push((name, flat));
            continue;
        }
        let name = format!("{}/{}", path, key.trim_matches('/'));
        match value {
            Value::Map(inner) => collect(inner, &name, out)?,
            other => {
                return Err(format!(
                    "{name}: {} where a node section (a mapping holding ros__parameters) belongs",
                    other.kind()
                ))
            }
        }
    }
    Ok(())
}

/// Nested parameter mappings as dotted names (`a: {b: 1}` is `a.b`), as rcl names them.
fn flatten(map: &[(String, Value)], prefix: &str, out: &mut Vec<(String, Value)>) {
    for (key, value) in map {
        let name = format!("{prefix}{key}");
        match value {
            Value::Map(inner) => flatten(inner, &format!("{name}."), out),
            v => out.push((name, v.clone())),
        }
    }
}

impl ExploreParams {
    /// Reads `path` for the node whose fully qualified name is `node` (`/robot0/explore_node`).
    pub fn from_file(path: &Path, node: &str) -> Result<Self, ParamsError> {
        Self::from_files(&[path], node)
    }

    /// Reads `paths` in order for node `node`, as a ROS node takes several `--params-file`:
    /// each file's sections for the node apply over what the files before set. It is an error
    /// when no file has a section for the node.
    pub fn from_files(paths: &[&Path], node: &str) -> Result<Self, ParamsError> {
        let mut p = ExploreParams::default();
        let mut misses = Vec::new();
        for path in paths {
            let file = path.display().to_string();
            let text = madenet_files::read_text_capped(path, madenet_files::InputKind::Config)
                .map_err(|source| ParamsError::Read {
                    file: file.clone(),
                    source,
                })?;
            if let Err(miss) = p.apply(&text, node, &file) {
                match miss {
                    ParamsError::NoSection { .. } if paths.len() > 1 => misses.push(miss),
                    e => return Err(e),
                }
            }
        }
        if misses.len() == paths.len() {
            return Err(misses.remove(0));
        }
        p.checked(
            &paths
                .last()
                .map(|f| f.display().to_string())
                .unwrap_or_default(),
        )
    }

    /// [`ExploreParams::from_file`] on YAML text.
    pub fn from_yaml(text: &str, node: &str) -> Result<Self, ParamsError> {
        let mut p = ExploreParams::default();
        p.apply(text, node, "parameters")?;
        p.checked("parameters")
    }

    fn checked(self, file: &str) -> Result<Self, ParamsError> {
        self.validate()
            .map_err(|(name, why)| ParamsError::Parameter {
                file: file.to_string(),
                section: "(all)".into(),
                name: name.into(),
                why,
            })?;
        Ok(self)
    }

    /// Applies the sections of `text` (file `file`) that apply to `node` over these values.
    fn apply(&mut self, text: &str, node: &str, file: &str) -> Result<(), ParamsError> {
        let format = |why: String| ParamsError::Format {
            file: file.to_string(),
            why,
        };
        let doc: Value = serde_saphyr::from_str(text).map_err(|e| {
            let why = e.without_snippet().to_string();
            let why = why.lines().next().unwrap_or("").trim().to_string();
            // The line it is on names the parameter (`progress_timeout: .nan`).
            let at = e
                .location()
                .and_then(|l| usize::try_from(l.line()).ok()?.checked_sub(1));
            match at.and_then(|k| text.lines().nth(k)) {
                Some(line) => format(format!("{why} (`{}`)", line.trim())),
                None => format(why),
            }
        })?;
        let Value::Map(top) = doc else {
            return Err(format(format!(
                "a ROS 2 parameter file is a mapping of node sections, not {}",
                doc.kind()
            )));
        };
        let mut sections = Sections::new();
        collect(&top, "", &mut sections).map_err(format)?;
        if sections.is_empty() {
            return Err(format(
                "no node section (a key holding ros__parameters)".into(),
            ));
        }
        let node = if node.starts_with('/') {
            node.to_string()
        } else {
            format!("/{node}")
        };
        // rclcpp: `/**` first, then the node's own name (its values win); file order within.
        let mut applied = 0;
        let p = self;
        for want in ["/**", node.as_str()] {
            for (section, params) in sections.iter().filter(|(s, _)| s == want) {
                applied += 1;
                for (name, value) in params {
                    p.set(name, value).map_err(|why| ParamsError::Parameter {
                        file: file.to_string(),
                        section: section.clone(),
                        name: name.clone(),
                        why,
                    })?;
                }
            }
        }
        if applied == 0 {
            let names: Vec<&str> = sections.iter().map(|(s, _)| s.as_str()).collect();
            return Err(ParamsError::NoSection {
                file: file.to_string(),
                node,
                sections: names.join(", "),
            });
        }
        Ok(())
    }

    /// Sets parameter `name` to `value`, typed as explore_lite declares it.
    fn set(&mut self, name: &str, value: &Value) -> Result<(), String> {
        let wrong = |want: &str| {
            let hint = match (want, value) {
                ("a double", Value::Int(i)) => {
                    format!(" (write {i}.0: ROS 2 does not take an integer for a double)")
                }
                _ => String::new(),
            };
            Err(format!("expected {want}, got {}{hint}", value.kind()))
        };
        let text = |field: &mut String| match value {
            Value::Str(s) => {
                *field = s.clone();
                Ok(())
            }
            _ => wrong("a string"),
        };
        let double = |field: &mut f64| match value {
            Value::Float(f) => {
                *field = *f;
                Ok(())
            }
            _ => wrong("a double"),
        };
        let flag = |field: &mut bool| match value {
            Value::Bool(b) => {
                *field = *b;
                Ok(())
            }
            _ => wrong("a bool"),
        };
        match name {
            "robot_base_frame" => text(&mut self.robot_base_frame),
            "costmap_topic" => text(&mut self.costmap_topic),
            "costmap_updates_topic" => text(&mut self.costmap_updates_topic),
            "visualize" => flag(&mut self.visualize),
            "planner_frequency" => double(&mut self.planner_frequency),
            "progress_timeout" => double(&mut self.progress_timeout),
            "potential_scale" => double(&mut self.potential_scale),
            "orientation_scale" => double(&mut self.orientation_scale),
            "gain_scale" => double(&mut self.gain_scale),
            "transform_tolerance" => double(&mut self.transform_tolerance),
            "min_frontier_size" => double(&mut self.min_frontier_size),
            "return_to_init" => flag(&mut self.return_to_init),
            "use_sim_time" => flag(&mut self.use_sim_time),
            "policy" => text(&mut self.policy),
            "decision_frequency" => double(&mut self.decision_frequency),
            "teammates" => match value {
                Value::List(items) => {
                    let mut names = Vec::with_capacity(items.len());
                    for item in items {
                        match item {
                            Value::Str(s) => names.push(s.clone()),
                            other => {
                                return Err(format!(
                                    "expected a string array, got {} in it",
                                    other.kind()
                                ))
                            }
                        }
                    }
                    self.teammates = names;
                    Ok(())
                }
                _ => wrong("a string array"),
            },
            _ => Err(format!(
                "unknown (explore_lite's parameters: {}; madenet's: policy, teammates, decision_frequency; ROS's: use_sim_time)",
                EXPLORE_LITE.join(", ")
            )),
        }
    }

    /// Values in range: (parameter, why) of the first that is not.
    fn validate(&self) -> Result<(), (&'static str, String)> {
        let positive = |name: &'static str, v: f64, max: f64| {
            if v.is_finite() && v > 0.0 && v <= max {
                Ok(())
            } else {
                Err((name, format!("must be in (0, {max}], got {v}")))
            }
        };
        let non_negative = |name: &'static str, v: f64, max: f64| {
            if v.is_finite() && (0.0..=max).contains(&v) {
                Ok(())
            } else {
                Err((name, format!("must be in [0, {max}], got {v}")))
            }
        };
        let finite = |name: &'static str, v: f64| {
            if v.is_finite() {
                Ok(())
            } else {
                Err((name, format!("must be a finite number, got {v}")))
            }
        };
        positive("planner_frequency", self.planner_frequency, 1000.0)?;
        positive("decision_frequency", self.decision_frequency, 1000.0)?;
        positive("progress_timeout", self.progress_timeout, 86_400.0)?;
        non_negative("transform_tolerance", self.transform_tolerance, 3600.0)?;
        non_negative("min_frontier_size", self.min_frontier_size, 1000.0)?;
        finite("potential_scale", self.potential_scale)?;
        finite("orientation_scale", self.orientation_scale)?;
        finite("gain_scale", self.gain_scale)?;
        for (name, v) in [
            ("robot_base_frame", &self.robot_base_frame),
            ("costmap_topic", &self.costmap_topic),
            ("costmap_updates_topic", &self.costmap_updates_topic),
            ("policy", &self.policy),
        ] {
            if v.trim().is_empty() {
                return Err((name, "must not be empty".into()));
            }
        }
        for t in &self.teammates {
            let ok = t.starts_with('/')
                && t.len() > 1
                && t[1..].split('/').all(|seg| {
                    !seg.is_empty()
                        && !seg.starts_with(|c: char| c.is_ascii_digit())
                        && seg.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
                });
            if !ok {
                return Err((
                    "teammates",
                    format!("{t:?} is not a ROS namespace (/robot1)"),
                ));
            }
        }
        Ok(())
    }
}

/// explore_lite's parameters, as its README and `params.yaml` list them.
pub const EXPLORE_LITE: [&str; 12] = [
    "robot_base_frame",
    "costmap_topic",
    "costmap_updates_topic",
    "visualize",
    "planner_frequency",
    "progress_timeout",
    "potential_scale",
    "orientation_scale",
    "gain_scale",
    "transform_tolerance",
    "min_frontier_size",
    "return_to_init",
];
