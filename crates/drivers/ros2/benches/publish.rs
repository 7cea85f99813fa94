//! `cargo bench -p madenet-ros2 --bench publish`: what `--ros2` adds to a robot's timestep.
//! One robot's `RobotTopics::publish` (its map — one cell changed, so it is sent — and its
//! pose) into an in-process zenoh router with a subscriber on both topics, for maps of 20 × 20,
//! 60 × 60 and 200 × 200 cells, against encoding the same map alone as CDR (`cdr_only`, no
//! network). The run's decision-to-move latency over Zenoh (BENCHMARKS.md, ≈ 0.2 ms) is the
//! anchor: publishing should cost less than a timestep's own messages.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use madenet_map::{OccGrid, Occupancy, Pos};
use madenet_ros2::msgs::RosMessage;
use madenet_ros2::{loopback_router, occupancy_grid, MapFrame, RobotTopics};
use zenoh::Wait;

fn bench(c: &mut Criterion) {
    let (router, opts) = loopback_router().expect("router");
    let received = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let count = received.clone();
    let _sub = router
        .declare_subscriber("0/robot0/**")
        .callback(move |_| {
            count.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        })
        .wait()
        .expect("subscriber");
    let ctx = opts.context().expect("session");
    let mut g = c.benchmark_group("ros2_publish");
    for side in [20usize, 60, 200] {
        let mut grid = OccGrid::new(side, side, Occupancy::Unknown);
        let frame = MapFrame::of(&grid);
        let mut topics = RobotTopics::new(&ctx, 0, frame).expect("publishers");
        let mut k = 0usize;
        g.bench_with_input(BenchmarkId::new("map_and_pose", side), &side, |b, _| {
            b.iter(|| {
                // One more cell known each timestep, as a robot's belief grows.
                k = (k + 1) % (side * side);
                let p = Pos::new((k / side) as i32, (k % side) as i32);
                let v = if grid.get(p) == Occupancy::Free {
                    Occupancy::Unknown
                } else {
                    Occupancy::Free
                };
                grid.set(p, v);
                topics.publish(grid.cells(), p, None).expect("publish");
            })
        });
        let msg = occupancy_grid(&frame, grid.cells(), Default::default());
        eprintln!(
            "{side} × {side}: map message {} B as CDR; {} samples received so far",
            msg.to_cdr().len(),
            received.load(std::sync::atomic::Ordering::Relaxed)
        );
        g.bench_with_input(BenchmarkId::new("cdr_only", side), &side, |b, _| {
            b.iter(|| occupancy_grid(&frame, grid.cells(), Default::default()).to_cdr())
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
