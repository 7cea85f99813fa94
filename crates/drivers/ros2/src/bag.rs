//! Runs recorded as ROS 2 bags: a rosbag2 directory — `metadata.yaml` and one MCAP file in the
//! ROS 2 profile (`cdr` messages, `ros2msg` schemas with the full definitions, ROS type names,
//! LZ4-compressed chunks) — that `ros2 bag info` / `ros2 bag play`, RViz, Foxglove and the
//! Python `rosbags` and `mcap` readers open. The messages are the same CDR the live topics
//! carry ([`crate::msgs`]).
//!
//! The bag is written into a hidden sibling directory and renamed into place by
//! [`Bag::finish`]; a bag dropped unfinished (an error, a full disk) removes it, so nothing
//! half-written is left behind as a bag (a process killed outright leaves the hidden folder).
//! Each topic carries the QoS it is offered with ([`crate::recorded_qos`]: maps reliable,
//! transient local, keep last 1; the rest reliable, volatile, keep last 10) in `metadata.yaml`
//! and in its MCAP channel, as rosbag2 writes them, so `ros2 bag play` republishes the maps
//! latched (RViz's map display, transient local, gets them without QoS overrides). Times are the caller's (madenet records simulated
//! time), so the same run gives the same bytes.
//!
//! ```
//! use madenet_ros2::bag::Bag;
//! use madenet_ros2::msgs::{Clock, Time};
//!
//! let dir = std::env::temp_dir().join(format!("madenet-bag-doc-{}", std::process::id()));
//! let mut bag = Bag::create(&dir).unwrap();
//! bag.write("/clock", &Clock { clock: Time { sec: 1, nanosec: 0 } }, 1_000_000_000).unwrap();
//! let dir = bag.finish().unwrap();
//! assert!(dir.join("metadata.yaml").is_file());
//! # std::fs::remove_dir_all(&dir).unwrap();
//! ```

use crate::msgs::RosMessage;
use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

/// What can go wrong writing a bag; the message names the path.
#[derive(Debug, thiserror::Error)]
pub enum BagError {
    /// The place is taken: a file, or a directory that is not empty.
    #[error("{0}: already exists (a file, or a folder that is not empty): choose a new name")]
    Exists(PathBuf),
    /// A file system error.
    #[error("{path}: {source}")]
    Io {
        /// Where.
        path: PathBuf,
        /// What.
        source: std::io::Error,
    },
    /// The MCAP writer's error (a full disk, say).
    #[error("{path}: writing MCAP: {why}")]
    Mcap {
        /// The MCAP file.
        path: PathBuf,
        /// Why.
        why: String,
    },
}

/// One topic of a bag: its MCAP channel, ROS type, type hash, offered QoS and message count.
struct Topic {
    channel: u16,
    type_name: &'static str,
    type_hash: String,
    qos: crate::QosProfile,
    count: u64,
}

/// `qos` as rosbag2 (Jazzy, metadata version 9) writes an offered QoS profile list of one: a
/// YAML sequence, each line indented by `indent` spaces; deadline, lifespan and liveliness
/// lease unset (`RMW_DURATION_INFINITE`), liveliness automatic.
fn qos_yaml(qos: &crate::QosProfile, indent: usize) -> String {
    const INFINITE: &str = "\n    sec: 9223372036\n    nsec: 854775807";
    let text = format!(
        "- history: keep_last\n  depth: {}\n  reliability: {}\n  durability: {}\n  deadline:{INFINITE}\n  lifespan:{INFINITE}\n  liveliness: automatic\n  liveliness_lease_duration:{INFINITE}\n  avoid_ros_namespace_conventions: false",
        qos.depth,
        match qos.reliability {
            crate::Reliability::Reliable => "reliable",
            crate::Reliability::BestEffort => "best_effort",
        },
        match qos.durability {
            crate::Durability::Volatile => "volatile",
            crate::Durability::TransientLocal => "transient_local",
        },
    );
    let pad = " ".repeat(indent);
    text.lines().map(|l| format!("{pad}{l}\n")).collect()
}

/// A rosbag2 directory being written ([module docs](self)).
pub struct Bag {
    dir: PathBuf,
    tmp: PathBuf,
    file: String,
    writer: Option<mcap::Writer<BufWriter<File>>>,
    topics: BTreeMap<String, Topic>,
    first_ns: Option<u64>,
    last_ns: u64,
    finished: bool,
    /// The place's lock ([`Bag::take_place`]): its file, held while the bag is written.
    lock: Option<(File, PathBuf)>,
}

impl Bag {
    /// Where a bag named `dir` goes: `dir` itself, or where it links to (a symbolic link to a
    /// folder, or to a path still to be made). A link to nothing is refused.
    fn place(dir: &Path) -> Result<PathBuf, BagError> {
        match std::fs::symlink_metadata(dir) {
            Ok(m) if m.file_type().is_symlink() => {
                std::fs::canonicalize(dir).map_err(|_| BagError::Io {
                    path: dir.to_path_buf(),
                    source: std::io::Error::new(
                        std::io::ErrorKind::NotFound,
                        "a symbolic link to nothing",
                    ),
                })
            }
            _ => Ok(dir.to_path_buf()),
        }
    }

    /// Holds the place `dir` for this process (the kernel's lock on a hidden file beside it,
    /// released however the process ends): a second run recording to the same place is refused
    /// at its start, not after its trial.
    fn take_place(dir: &Path, parent: &Path, name: &str) -> Result<(File, PathBuf), BagError> {
        let path = parent.join(format!(".{name}.madenet-bag.lock"));
        let io = |source| BagError::Io {
            path: dir.to_path_buf(),
            source,
        };
        let file = std::fs::OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&path)
            .map_err(io)?;
        match file.try_lock() {
            Ok(()) => Ok((file, path)),
            Err(std::fs::TryLockError::WouldBlock) => Err(io(std::io::Error::new(
                std::io::ErrorKind::WouldBlock,
                "another madenet run is recording a bag to this place",
            ))),
            Err(std::fs::TryLockError::Error(e)) => Err(io(e)),
        }
    }

    /// Gives the place up (its lock file removed, then the lock released).
    fn release_place(&mut self) {
        if let Some((file, path)) = self.lock.take() {
            let _ = std::fs::remove_file(path);
            drop(file);
        }
    }

    /// Refuses a place for a bag that is taken: a file, or a directory that is not empty.
    pub fn check_place(dir: &Path) -> Result<(), BagError> {
        let taken = |source| BagError::Io {
            path: dir.to_path_buf(),
            source,
        };
        if dir.is_file()
            || (dir.is_dir() && std::fs::read_dir(dir).map_err(taken)?.next().is_some())
            || (dir.exists() && !dir.is_dir())
        {
            return Err(BagError::Exists(dir.to_path_buf()));
        }
        Ok(())
    }

    /// Removes from `dir` the hidden folders of bags that were being written when their
    /// process died (`.NAME.partial-PID-K`, see [`Bag::create`]); how many. Only for a folder
    /// whose writers the caller has excluded (a study holding its output folder's lock).
    pub fn remove_leftovers(dir: &Path) -> std::io::Result<usize> {
        let mut n = 0;
        let Ok(list) = std::fs::read_dir(dir) else {
            return Ok(0);
        };
        for entry in list {
            let entry = entry?;
            let name = entry.file_name().to_string_lossy().into_owned();
            if name.starts_with('.') && name.contains(".partial-") && entry.file_type()?.is_dir() {
                std::fs::remove_dir_all(entry.path())?;
                n += 1;
            }
        }
        Ok(n)
    }

    /// Starts a bag that [`Bag::finish`] puts at `dir`: a new path, or an empty directory.
    pub fn create(dir: &Path) -> Result<Self, BagError> {
        let io = |path: &Path| {
            let path = path.to_path_buf();
            move |source| BagError::Io { path, source }
        };
        let dir = &Self::place(dir)?;
        let name = dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .filter(|n| !n.is_empty() && n != "." && n != "..")
            .ok_or_else(|| BagError::Io {
                path: dir.to_path_buf(),
                source: std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a folder name"),
            })?;
        let parent = match dir.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let lock = Self::take_place(dir, &parent, &name)?;
        let give_up = |e: BagError| {
            let _ = std::fs::remove_file(&lock.1);
            e
        };
        Self::check_place(dir).map_err(give_up)?;
        // A hidden sibling of our own (never one another bag is writing): the first free name.
        let mut k = 0u32;
        let tmp = loop {
            let tmp = parent.join(format!(".{name}.partial-{}-{k}", std::process::id()));
            match std::fs::create_dir(&tmp) {
                Ok(()) => break tmp,
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && k < 1000 => k += 1,
                Err(source) => {
                    return Err(give_up(BagError::Io {
                        path: dir.to_path_buf(),
                        source,
                    }))
                }
            }
        };
        let file = format!("{name}_0.mcap");
        let path = tmp.join(&file);
        let mut bag = Bag {
            dir: dir.to_path_buf(),
            tmp,
            file,
            writer: None,
            topics: BTreeMap::new(),
            first_ns: None,
            last_ns: 0,
            finished: false,
            lock: Some(lock),
        };
        let out = File::create(&path).map_err(io(dir))?;
        let opts = mcap::WriteOptions::new()
            .profile("ros2")
            .library("madenet")
            .compression(Some(mcap::Compression::Lz4))
            // Chunk CRCs on: with them off, mcap 0.26 still writes a data-section CRC, computed
            // without the chunks, that every validating reader refuses (issue 59).
            .calculate_chunk_crcs(true);
        bag.writer = Some(
            opts.create(BufWriter::new(out))
                .map_err(|e| bag.mcap_error(e))?,
        );
        Ok(bag)
    }

    /// The MCAP writer's error, named by the bag's place (the hidden folder goes with the
    /// error), with its cause (e.g. "No space left on device").
    fn mcap_error(&self, e: mcap::McapError) -> BagError {
        let mut why = e.to_string();
        let mut cause = std::error::Error::source(&e);
        while let Some(c) = cause {
            why = format!("{why}: {c}");
            cause = c.source();
        }
        BagError::Mcap {
            path: self.dir.clone(),
            why,
        }
    }

    /// Writes `msg` on `topic` at `t_ns` nanoseconds (the log and publish time); the topic's
    /// channel and schema are added on its first message.
    pub fn write<T: RosMessage>(
        &mut self,
        topic: &str,
        msg: &T,
        t_ns: u64,
    ) -> Result<(), BagError> {
        self.write_cdr::<T>(topic, &msg.to_cdr(), t_ns)
    }

    /// [`Bag::write`] for a message of type `T` already CDR-encoded (`cdr`: the bytes of
    /// [`RosMessage::to_cdr`]), so one encoding serves several outputs.
    pub fn write_cdr<T: RosMessage>(
        &mut self,
        topic: &str,
        cdr: &[u8],
        t_ns: u64,
    ) -> Result<(), BagError> {
        let writer = self.writer.as_mut().expect("open until finished");
        let channel = match self.topics.get(topic) {
            Some(t) => t.channel,
            None => {
                let schema = writer
                    .add_schema(T::TYPE_NAME, "ros2msg", T::DEFINITION.as_bytes())
                    .map_err(|e| self.mcap_error(e))?;
                let writer = self.writer.as_mut().expect("open");
                // rosbag2's MCAP channel metadata: the offered QoS and the type hash.
                let qos = crate::recorded_qos(topic);
                let meta = BTreeMap::from([
                    ("offered_qos_profiles".to_string(), qos_yaml(&qos, 0)),
                    ("topic_type_hash".to_string(), T::type_hash()),
                ]);
                let channel = writer
                    .add_channel(schema, topic, "cdr", &meta)
                    .map_err(|e| self.mcap_error(e))?;
                self.topics.insert(
                    topic.to_string(),
                    Topic {
                        channel,
                        type_name: T::TYPE_NAME,
                        type_hash: T::type_hash(),
                        qos,
                        count: 0,
                    },
                );
                channel
            }
        };
        let t = self.topics.get_mut(topic).expect("added above");
        t.count += 1;
        let header = mcap::records::MessageHeader {
            channel_id: channel,
            sequence: t.count as u32,
            log_time: t_ns,
            publish_time: t_ns,
        };
        self.first_ns.get_or_insert(t_ns);
        self.last_ns = self.last_ns.max(t_ns);
        let writer = self.writer.as_mut().expect("open");
        writer
            .write_to_known_channel(&header, cdr)
            .map_err(|e| self.mcap_error(e))
    }

    /// Messages written so far.
    pub fn messages(&self) -> u64 {
        self.topics.values().map(|t| t.count).sum()
    }

    /// Finishes the MCAP file, writes `metadata.yaml` and moves the bag into place; returns
    /// its directory.
    pub fn finish(mut self) -> Result<PathBuf, BagError> {
        let mut writer = self.writer.take().expect("open until finished");
        writer.finish().map_err(|e| self.mcap_error(e))?;
        // Flushed, not synced: rosbag2 does not `fsync` its bags either (issue 59); the bag
        // still appears whole or not at all (the rename below).
        let out = writer.into_inner();
        out.into_inner().map_err(|e| BagError::Io {
            path: self.dir.clone(),
            source: e.into_error(),
        })?;
        let meta = self.tmp.join("metadata.yaml");
        std::fs::write(&meta, self.metadata()).map_err(|source| BagError::Io {
            path: self.dir.clone(),
            source,
        })?;
        if self.dir.is_dir() {
            // An empty folder the caller named (checked at the start): the bag takes its place.
            std::fs::remove_dir(&self.dir).map_err(|source| BagError::Io {
                path: self.dir.clone(),
                source,
            })?;
        }
        std::fs::rename(&self.tmp, &self.dir).map_err(|source| BagError::Io {
            path: self.dir.clone(),
            source,
        })?;
        self.finished = true;
        self.release_place();
        Ok(self.dir.clone())
    }

    /// rosbag2's `metadata.yaml` (version 9, Jazzy's) for what was written; names and paths
    /// as double-quoted YAML strings (a JSON string is one), whatever characters they hold.
    fn metadata(&self) -> String {
        let q = |s: &str| serde_json::to_string(s).expect("a string serializes");
        let start = self.first_ns.unwrap_or(0);
        let duration = self.last_ns.saturating_sub(start);
        let count = self.messages();
        let mut y = String::new();
        y.push_str("rosbag2_bagfile_information:\n");
        y.push_str("  version: 9\n");
        y.push_str("  storage_identifier: mcap\n");
        y.push_str(&format!("  duration:\n    nanoseconds: {duration}\n"));
        y.push_str(&format!(
            "  starting_time:\n    nanoseconds_since_epoch: {start}\n"
        ));
        y.push_str(&format!("  message_count: {count}\n"));
        y.push_str("  topics_with_message_count:\n");
        for (name, t) in &self.topics {
            y.push_str("    - topic_metadata:\n");
            y.push_str(&format!("        name: {}\n", q(name)));
            y.push_str(&format!("        type: {}\n", q(t.type_name)));
            y.push_str("        serialization_format: cdr\n");
            y.push_str("        offered_qos_profiles:\n");
            y.push_str(&qos_yaml(&t.qos, 10));
            y.push_str(&format!(
                "        type_description_hash: {}\n",
                q(&t.type_hash)
            ));
            y.push_str(&format!("      message_count: {}\n", t.count));
        }
        y.push_str("  compression_format: \"\"\n");
        y.push_str("  compression_mode: \"\"\n");
        y.push_str(&format!(
            "  relative_file_paths:\n    - {}\n",
            q(&self.file)
        ));
        y.push_str("  files:\n");
        y.push_str(&format!("    - path: {}\n", q(&self.file)));
        y.push_str(&format!(
            "      starting_time:\n        nanoseconds_since_epoch: {start}\n"
        ));
        y.push_str(&format!(
            "      duration:\n        nanoseconds: {duration}\n"
        ));
        y.push_str(&format!("      message_count: {count}\n"));
        y.push_str("  custom_data: ~\n");
        y.push_str("  ros_distro: jazzy\n");
        y
    }
}

impl Drop for Bag {
    fn drop(&mut self) {
        if !self.finished {
            // Unfinished (an error on the way): no half-written bag is left behind.
            self.writer.take();
            let _ = std::fs::remove_dir_all(&self.tmp);
        }
        self.release_place();
    }
}
