//! madenet's side of the outside wire checks (`interop/test_ros2_wire.py`, run in CI with
//! the Python `eclipse-zenoh` and `rosbags` packages, which know nothing of madenet):
//!
//! - `ros2_wire hashes`: every registered type and its RIHS01 hash, one per line;
//! - `ros2_wire serve-add ENDPOINT N`: serves `/add_two_ints` until N requests were answered;
//! - `ros2_wire call-add ENDPOINT A B`: calls `/add_two_ints` and prints the sum;
//! - `ros2_wire serve-fib ENDPOINT N`: serves the Fibonacci action `/fibonacci` (feedback
//!   every 50 ms; cancel works) until N goals ended;
//! - `ros2_wire send-fib ENDPOINT ORDER`: sends a Fibonacci goal, prints each feedback's
//!   length, then the final status and sequence.
//!
//! - `ros2_wire nav2-sim ENDPOINT SEED`: one simulated nav2 robot (`/robot0`, the continuous
//!   world on a 20 m generated floor plan) at 40× real time; prints `goal X Y` for ten
//!   reachable points of the `map` frame (its server is up when its `navigate_to_pose` liveliness
//!   tokens are); runs until its stdin closes, then
//!   prints `outcomes …` and `collisions N`.
//!
//! ENDPOINT is a zenoh endpoint such as `tcp/127.0.0.1:7447` (a router or a listening peer).

use madenet_ros2::actions::{
    status, ActionClient, ActionEvent, ActionServer, Fibonacci, FibonacciGoal, FibonacciSequence,
};
use madenet_ros2::services::{AddTwoInts, AddTwoIntsResponse, ServiceClient, ServiceServer};
use madenet_ros2::Ros2Options;
use std::process::ExitCode;
use std::time::{Duration, Instant};

const WAIT: Duration = Duration::from_secs(30);

fn context(endpoint: &str) -> Result<madenet_ros2::Ros2Context, String> {
    Ros2Options {
        connect: vec![endpoint.to_string()],
        listen: Vec::new(),
        domain_id: Some(0),
    }
    .context()
    .map_err(|e| e.to_string())
}

fn number<T: std::str::FromStr>(args: &[String], i: usize, what: &str) -> Result<T, String> {
    args.get(i)
        .ok_or(format!("missing {what}"))?
        .parse()
        .map_err(|_| format!("{what}: {:?} is not a number", args[i]))
}

fn serve_fib(endpoint: &str, goals: usize) -> Result<(), String> {
    let ctx = context(endpoint)?;
    let node = ctx.create_node("fib_server").map_err(|e| e.to_string())?;
    let mut server =
        ActionServer::<Fibonacci>::new(&node, "/fibonacci").map_err(|e| e.to_string())?;
    println!("ready");
    let mut ended = 0;
    let mut running = None;
    let mut last = Instant::now();
    let deadline = Instant::now() + Duration::from_secs(120);
    while ended < goals && Instant::now() < deadline {
        match server
            .poll(Duration::from_millis(10))
            .map_err(|e| e.to_string())?
        {
            Some(ActionEvent::Goal(g)) if g.goal().order >= 0 => {
                let order = g.goal().order;
                running = Some((
                    server.accept(g).map_err(|e| e.to_string())?,
                    order,
                    vec![0, 1],
                ));
            }
            Some(ActionEvent::Goal(g)) => server.reject(g).map_err(|e| e.to_string())?,
            Some(ActionEvent::Cancel(id)) => {
                if let Some((_, _, seq)) = running.take_if(|r| r.0 == id) {
                    server
                        .end(id, status::CANCELED, FibonacciSequence { sequence: seq })
                        .map_err(|e| e.to_string())?;
                    ended += 1;
                }
            }
            None => {}
        }
        if last.elapsed() >= Duration::from_millis(50) {
            last = Instant::now();
            if let Some((id, order, seq)) = running.as_mut() {
                if seq.len() as i32 > *order {
                    let sequence = std::mem::take(seq);
                    server
                        .end(*id, status::SUCCEEDED, FibonacciSequence { sequence })
                        .map_err(|e| e.to_string())?;
                    running = None;
                    ended += 1;
                } else {
                    seq.push(seq[seq.len() - 1] + seq[seq.len() - 2]);
                    let sequence = seq.clone();
                    server
                        .publish_feedback(*id, FibonacciSequence { sequence })
                        .map_err(|e| e.to_string())?;
                }
            }
        }
    }
    // Answer late `get_result` requests for the ended goals for a second, then close.
    let linger = Instant::now() + Duration::from_secs(1);
    while Instant::now() < linger {
        server
            .poll(Duration::from_millis(10))
            .map_err(|e| e.to_string())?;
    }
    println!("refused {}", server.refused());
    Ok(())
}

fn send_fib(endpoint: &str, order: i32) -> Result<(), String> {
    let ctx = context(endpoint)?;
    let node = ctx.create_node("fib_client").map_err(|e| e.to_string())?;
    let client = ActionClient::<Fibonacci>::new(&node, "/fibonacci").map_err(|e| e.to_string())?;
    if !client.wait_for_server(WAIT).map_err(|e| e.to_string())? {
        return Err("no /fibonacci server".into());
    }
    let goal = client
        .send_goal(FibonacciGoal { order }, WAIT)
        .map_err(|e| e.to_string())?
        .ok_or("goal rejected")?;
    let deadline = Instant::now() + WAIT;
    while Instant::now() < deadline {
        if let Some(fb) = client
            .feedback(Duration::from_millis(20))
            .map_err(|e| e.to_string())?
        {
            if fb.goal_id == goal.id {
                println!("feedback {}", fb.feedback.sequence.len());
            }
        }
        if let Some((st, result)) = goal
            .result(Duration::from_millis(20))
            .map_err(|e| e.to_string())?
        {
            println!("status {st} sequence {:?}", result.sequence);
            return Ok(());
        }
    }
    Err("no result".into())
}

fn nav2_sim(endpoint: &str, seed: u64) -> Result<(), String> {
    use madenet_continuous::{ContinuousConfig, ContinuousWorld, Scene};
    use madenet_map::floorplan::{floor_plan, FloorPlanConfig};
    use madenet_map::generate::reachable_from_with;
    use madenet_map::{Movement, Occupancy};
    use madenet_ros2::nav2_sim::{run_nav2_sim, Nav2SimOptions};
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;

    let mut cfg = FloorPlanConfig::for_size(20, 20);
    cfg.door_width = 1;
    let grid = floor_plan(&cfg, seed).map_err(|e| e.to_string())?;
    let start = cfg.keep_free[0];
    let frame = madenet_ros2::MapFrame::of(&grid);
    let reach = reachable_from_with(&grid, start, Movement::NoCornerCutting);
    let free: Vec<usize> = (0..grid.len())
        .filter(|&k| reach[k] && grid.cells()[k] == Occupancy::Free)
        .collect();
    for j in 0..20 {
        let (x, y) = frame.cell_center(grid.pos(free[(j * 37 + 11) % free.len()]));
        println!("goal {x} {y}");
    }
    let scene = Arc::new(Scene::from_grid(&grid, "plan"));
    let scenario = madenet_world::ScenarioConfig {
        num_robots: 1,
        ..Default::default()
    };
    let world = ContinuousWorld::new(scene, &[start], scenario, ContinuousConfig::default(), seed)
        .map_err(|e| e.to_string())?;
    let opts = madenet_ros2::Ros2Options {
        connect: vec![endpoint.to_string()],
        listen: Vec::new(),
        domain_id: Some(0),
    };
    let stop = Arc::new(AtomicBool::new(false));
    let halt = stop.clone();
    // Stops when stdin closes.
    std::thread::spawn(move || {
        let _ = std::io::copy(&mut std::io::stdin(), &mut std::io::sink());
        halt.store(true, Ordering::Relaxed);
    });
    let sim = Nav2SimOptions {
        realtime: 40.0,
        ..Default::default()
    };
    let run = run_nav2_sim(&opts, world, &sim, &stop).map_err(|e| e.to_string())?;
    let outcomes: Vec<String> = run.outcomes[0]
        .iter()
        .map(|o| format!("{}:{}", o.status, o.error_code))
        .collect();
    println!("outcomes {}", outcomes.join(" "));
    println!("rejected {}", run.rejected);
    println!("refused {}", run.refused);
    println!(
        "collisions {}",
        run.collisions.obstacle + run.collisions.robot
    );
    Ok(())
}

fn run(args: &[String]) -> Result<(), String> {
    let usage = "usage: ros2_wire hashes | serve-add ENDPOINT N | call-add ENDPOINT A B | serve-fib ENDPOINT N | send-fib ENDPOINT ORDER | nav2-sim ENDPOINT SEED";
    match args.first().map(String::as_str) {
        Some("hashes") => {
            for name in madenet_ros2::typehash::jazzy_types().names() {
                println!("{name} {}", madenet_ros2::typehash::jazzy_hash(name));
            }
            Ok(())
        }
        Some("serve-add") => {
            let ctx = context(args.get(1).ok_or(usage)?)?;
            let n: usize = number(args, 2, "N")?;
            let node = ctx.create_node("adder").map_err(|e| e.to_string())?;
            let server = ServiceServer::<AddTwoInts>::new(&node, "/add_two_ints")
                .map_err(|e| e.to_string())?;
            println!("ready");
            let mut answered = 0;
            while answered < n {
                let req = server
                    .recv_timeout(WAIT)
                    .map_err(|e| e.to_string())?
                    .ok_or("no request within 30 s")?;
                let sum = req.request.a.wrapping_add(req.request.b);
                req.reply(&AddTwoIntsResponse { sum })
                    .map_err(|e| e.to_string())?;
                answered += 1;
            }
            std::thread::sleep(Duration::from_millis(300));
            println!("refused {}", server.refused());
            Ok(())
        }
        Some("call-add") => {
            let ctx = context(args.get(1).ok_or(usage)?)?;
            let (a, b) = (number(args, 2, "A")?, number(args, 3, "B")?);
            let node = ctx.create_node("caller").map_err(|e| e.to_string())?;
            let client = ServiceClient::<AddTwoInts>::new(&node, "/add_two_ints")
                .map_err(|e| e.to_string())?;
            if !client.wait_for_server(WAIT).map_err(|e| e.to_string())? {
                return Err("no /add_two_ints server".into());
            }
            let r = client
                .call(&madenet_ros2::services::AddTwoIntsRequest { a, b }, WAIT)
                .map_err(|e| e.to_string())?;
            println!("sum {}", r.sum);
            Ok(())
        }
        Some("serve-fib") => serve_fib(args.get(1).ok_or(usage)?, number(args, 2, "N")?),
        Some("nav2-sim") => nav2_sim(args.get(1).ok_or(usage)?, number(args, 2, "SEED")?),
        Some("send-fib") => send_fib(args.get(1).ok_or(usage)?, number(args, 2, "ORDER")?),
        _ => Err(usage.into()),
    }
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("ros2_wire: {e}");
            ExitCode::from(2)
        }
    }
}
