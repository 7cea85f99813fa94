//! `cargo bench -p madenet-ros2 --bench record`: what `--record` costs a paper trial (issue 30
//! asks ≤ 25 % of the trial's own time) — the same trial (test_3, top-right, `spread`, seed 1)
//! run alone and run recorded into a bag (written and finished; the benchmark's removal of the
//! bag afterwards is not timed).
//!
//! * `paper_trial/plain`
//! * `paper_trial/recorded`
//! * `paper_trial/encoded_only` (every message built and CDR-encoded, no bag: the per-message
//!   cost without the file)
//! * `paper_trial/empty_bag` (the fixed cost: the true map and the first timestep only)
//! * `paper_trial/fs_floor` (no madenet code: the file operations that put this trial's finished
//!   bag on disk — a hidden folder, its `.mcap` written from ready bytes and synced, its
//!   `metadata.yaml`, the rename — what any recorder writing the same bag pays) and
//!   `paper_trial/fs_floor_unsynced` (the same without the `fsync`)

use criterion::{criterion_group, criterion_main, Criterion};
use madenet_map::paper::{paper_map, Corner};
use madenet_ros2::record::Recorder;
use madenet_sim::{Trial, TrialSpec};
use std::time::{Duration, Instant};

fn spec() -> TrialSpec {
    let map = paper_map(3).expect("paper map 3");
    let starts = Corner::TopRight
        .start_cells(map.height(), map.width())
        .to_vec();
    TrialSpec {
        map,
        map_name: "test_3".into(),
        starts,
        config: Default::default(),
        policy: "spread".into(),
        seed: 1,
    }
}

/// Times `record` (which writes a bag at the path it is given and returns it) `iters` times;
/// the benchmark's own removal of each bag is not timed.
fn timed_bags(
    iters: u64,
    dir: &std::path::Path,
    mut record: impl FnMut(&std::path::Path) -> std::path::PathBuf,
) -> Duration {
    let mut total = Duration::ZERO;
    for _ in 0..iters {
        let start = Instant::now();
        let at = record(dir);
        total += start.elapsed();
        std::fs::remove_dir_all(at).expect("removed");
    }
    total
}

fn bench(c: &mut Criterion) {
    let spec = spec();
    let dir = std::env::temp_dir().join(format!("madenet-bench-record-{}", std::process::id()));
    let mut g = c.benchmark_group("paper_trial");
    g.bench_function("plain", |b| {
        b.iter(|| {
            let mut trial = Trial::new(spec.clone()).expect("trial");
            while trial.step() {}
            trial.finish()
        })
    });
    g.bench_function("recorded", |b| {
        b.iter_custom(|iters| {
            timed_bags(iters, &dir, |dir| {
                let mut trial = Trial::new(spec.clone()).expect("trial");
                let mut bag = Recorder::start(dir, &trial).expect("bag");
                while trial.step() {
                    bag.step(&trial).expect("recorded");
                }
                let (at, _) = bag.finish(&trial).expect("finished").expect("a bag");
                std::hint::black_box(trial.finish());
                at
            })
        })
    });
    g.bench_function("encoded_only", |b| {
        b.iter(|| {
            let mut trial = Trial::new(spec.clone()).expect("trial");
            let mut rec = Recorder::to(None, &trial).expect("recorder");
            while trial.step() {
                rec.step(&trial).expect("encoded");
            }
            rec.finish(&trial).expect("finished");
            trial.finish()
        })
    });
    g.bench_function("empty_bag", |b| {
        b.iter_custom(|iters| {
            timed_bags(iters, &dir, |dir| {
                let trial = Trial::new(spec.clone()).expect("trial");
                let bag = Recorder::start(dir, &trial).expect("bag");
                bag.finish(&trial).expect("finished").expect("a bag").0
            })
        })
    });
    // The trial's finished bag, read back once: the bytes the floor writes.
    let made = {
        let mut trial = Trial::new(spec.clone()).expect("trial");
        let mut bag = Recorder::start(&dir, &trial).expect("bag");
        while trial.step() {
            bag.step(&trial).expect("recorded");
        }
        bag.finish(&trial).expect("finished").expect("a bag").0
    };
    let mut files: Vec<(std::ffi::OsString, Vec<u8>)> = std::fs::read_dir(&made)
        .expect("bag folder")
        .map(|e| {
            let e = e.expect("entry");
            (e.file_name(), std::fs::read(e.path()).expect("bag file"))
        })
        .collect();
    std::fs::remove_dir_all(&made).expect("removed");
    // The `.mcap` first, as the recorder writes it (metadata.yaml after the sync).
    files.sort_by_key(|(name, _)| name.to_string_lossy() == "metadata.yaml");
    for (name, synced) in [("fs_floor", true), ("fs_floor_unsynced", false)] {
        g.bench_function(name, |b| {
            b.iter_custom(|iters| timed_bags(iters, &dir, |dir| write_floor(dir, &files, synced)))
        });
    }
    g.finish();
    continuous(c, &dir);
}

/// `continuous_trial/plain` and `continuous_trial/recorded`: a 20 m cluttered continuous trial
/// (3 robots bottom-left, `spread`, seed 1) alone and recorded with every topic (scans, fine
/// maps, poses, TF, clock, metrics); issue 59 asks ≤ 25 % more.
fn continuous(c: &mut Criterion, dir: &std::path::Path) {
    use madenet_sim::continuous::{ContinuousSpec, ContinuousTrial};
    let scene = madenet_continuous::scene::generate_cluttered(20.0, 0.1, 1);
    let spec = ContinuousSpec {
        scene: std::sync::Arc::new(scene),
        starts: Corner::BottomLeft.start_cells(20, 20).to_vec(),
        config: Default::default(),
        continuous: Default::default(),
        policy: "spread".into(),
        seed: 1,
    };
    let registry = madenet_sim::PolicyRegistry::builtin();
    let trial = || ContinuousTrial::new(spec.clone(), &registry).expect("trial");
    let mut g = c.benchmark_group("continuous_trial");
    g.sample_size(10);
    g.bench_function("plain", |b| {
        b.iter(|| {
            let mut t = trial();
            while t.step() {}
            t.finish()
        })
    });
    g.bench_function("recorded", |b| {
        b.iter_custom(|iters| {
            timed_bags(iters, dir, |dir| {
                let mut t = trial();
                let mut bag = Recorder::start(dir, &t).expect("bag");
                while t.step() {
                    bag.step(&t).expect("recorded");
                }
                let (at, _) = bag.finish(&t).expect("finished").expect("a bag");
                std::hint::black_box(t.finish());
                at
            })
        })
    });
    g.finish();
}

/// A bag's file operations alone: `files` (name, bytes) into a hidden folder beside `dir`, the
/// first synced when `synced`, then the folder renamed to `dir`.
fn write_floor(
    dir: &std::path::Path,
    files: &[(std::ffi::OsString, Vec<u8>)],
    synced: bool,
) -> std::path::PathBuf {
    use std::io::Write;
    let tmp = dir.with_file_name(format!(".floor-tmp-{}", std::process::id()));
    std::fs::create_dir(&tmp).expect("hidden folder");
    for (k, (name, bytes)) in files.iter().enumerate() {
        let mut f = std::fs::File::create(tmp.join(name)).expect("file");
        f.write_all(bytes).expect("written");
        if synced && k == 0 {
            f.sync_all().expect("synced");
        }
    }
    std::fs::rename(&tmp, dir).expect("renamed");
    dir.to_path_buf()
}

criterion_group!(benches, bench);
criterion_main!(benches);
