"""`madenet run --record`: the bag read by readers nobody here wrote — the `mcap` package with
`mcap-ros2-support`, and `rosbags` with its ROS 2 Jazzy typestore."""

import json
import re
import subprocess
from pathlib import Path

import numpy as np
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore
from ruamel.yaml import YAML

ARGS = ["run", "--map", "paper:3", "--start", "top-right", "--policy", "nf", "--seed", "2"]


def record(cli, path):
    out = subprocess.run([cli, *ARGS, "--json", "--trajectory", "--record", str(path)],
                         check=True, capture_output=True, text=True)
    return json.loads(out.stdout)


def cell(msg_pose, height):
    """The madenet cell (row, col) of a pose on a 1 m grid with origin 0 (ROS y up)."""
    x, y = msg_pose.position.x, msg_pose.position.y
    return (height - 1 - int(np.floor(y)), int(np.floor(x)))


def grid(msg):
    """An OccupancyGrid as madenet's rows (row 0 on top): −1, 0, 100."""
    return np.array(msg.data, dtype=np.int8).reshape(msg.info.height, msg.info.width)[::-1]


def test_the_bag_decodes_with_mcap_and_rosbags_and_is_the_trial(cli, tmp_path):
    result = record(cli, tmp_path / "trial")
    bag = tmp_path / "trial"
    assert sorted(p.name for p in bag.iterdir()) == ["metadata.yaml", "trial_0.mcap"]
    # mcap + mcap-ros2-support: every message decodes with the schemas in the file.
    by_topic = {}
    with open(bag / "trial_0.mcap", "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        for schema, channel, message, msg in reader.iter_decoded_messages():
            assert schema.encoding == "ros2msg" and channel.message_encoding == "cdr"
            by_topic.setdefault(channel.topic, []).append((message.log_time, msg))
    # rosbags: the directory (metadata.yaml and MCAP) with its own Jazzy definitions.
    typestore = get_typestore(Stores.ROS2_JAZZY)
    count = 0
    with AnyReader([bag], default_typestore=typestore) as reader:
        total = reader.message_count
        assert total == sum(len(v) for v in by_topic.values())
        for conn, t, raw in reader.messages():
            reader.deserialize(raw, conn.msgtype)
            count += 1
    assert count == total
    # The offered QoS, as rosbag2 writes it: in metadata.yaml (rosbags reads it there) and in
    # each MCAP channel's metadata. Maps latched (transient local, keep last 1), the rest volatile.
    with AnyReader([bag], default_typestore=typestore) as reader:
        qos = {c.topic: c.ext.offered_qos_profiles for c in reader.connections}
    with open(bag / "trial_0.mcap", "rb") as f:
        channels = make_reader(f).get_summary().channels.values()
        in_mcap = {c.topic: YAML(typ="safe").load(c.metadata["offered_qos_profiles"]) for c in channels}
    assert set(qos) == set(in_mcap) == set(by_topic)
    for topic, (profile,) in qos.items():
        (listed,) = in_mcap[topic]
        latched = topic.endswith("map")
        assert profile.durability.name == ("TRANSIENT_LOCAL" if latched else "VOLATILE"), topic
        assert profile.reliability.name == "RELIABLE" and profile.depth == (1 if latched else 10)
        assert listed["durability"] == profile.durability.name.lower() and listed["depth"] == profile.depth
    # Poses: one per timestep, the start and the end included, equal to the trajectory.
    steps = result["trajectory"]
    positions = [result["starts"]] + [s["positions"] for s in steps]
    truth = by_topic["/truth_map"][0][1]
    h = truth.info.height
    for i in range(3):
        poses = by_topic[f"/robot{i}/pose"]
        assert [t for t, _ in poses] == [k * 10**9 for k in range(len(positions))]
        assert [cell(m.pose, h) for _, m in poses] == [(p[i]["row"], p[i]["col"]) for p in positions]
    assert len(by_topic["/clock"]) == len(positions)
    assert len(by_topic["/tf"]) == len(positions)
    # The last team map: every robot's last map merged, and no frontier left.
    team = grid(by_topic["/team_map"][-1][1])
    merged = np.full_like(team, -1)
    for i in range(3):
        m = grid(by_topic[f"/robot{i}/map"][-1][1])
        merged = np.where(merged == -1, m, np.where((merged == 0) & (m == 100), 100, merged))
    assert (team == merged).all()
    free, unknown = team == 0, team == -1
    near_unknown = np.zeros_like(free)
    near_unknown[1:] |= unknown[:-1]
    near_unknown[:-1] |= unknown[1:]
    near_unknown[:, 1:] |= unknown[:, :-1]
    near_unknown[:, :-1] |= unknown[:, 1:]
    assert result["metrics"]["completed"] and not (free & near_unknown).any()


def test_every_crc_of_the_bag_is_valid(cli, tmp_path):
    """The `mcap` package's stream reader with CRC validation reads both worlds' bags whole:
    chunk CRCs and the data section's CRC."""
    from mcap.stream_reader import StreamReader
    from mcap.records import Chunk, DataEnd

    record(cli, tmp_path / "grid")
    subprocess.run([cli, "run", "--world", "continuous", "--map", "paper:3", "--start", "top-right",
                    "--policy", "nf", "--record", str(tmp_path / "cont")], check=True, capture_output=True)
    for name in ["grid", "cont"]:
        (path,) = (tmp_path / name).glob("*.mcap")
        with open(path, "rb") as f:
            records = list(StreamReader(f, validate_crcs=True).records)
        (end,) = [r for r in records if isinstance(r, DataEnd)]
        with open(path, "rb") as f:
            chunks = [r for r in StreamReader(f, emit_chunks=True).records if isinstance(r, Chunk)]
        assert chunks and all(c.uncompressed_crc != 0 for c in chunks), name
        assert end.data_section_crc != 0, name


def test_the_same_seed_gives_the_same_bytes(cli, tmp_path):
    record(cli, tmp_path / "a")
    record(cli, tmp_path / "b")
    assert (tmp_path / "a/a_0.mcap").read_bytes() == (tmp_path / "b/b_0.mcap").read_bytes()
    meta = lambda p: (tmp_path / p / "metadata.yaml").read_text().replace(f"{p}_0.mcap", "X")
    assert meta("a") == meta("b")


def decoded(path):
    """Every message of a bag, by topic: (log time, message), read by `rosbags` (Jazzy)."""
    by_topic = {}
    with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
        for conn, t, raw in reader.messages():
            by_topic.setdefault(conn.topic, []).append((t, reader.deserialize(raw, conn.msgtype)))
    return by_topic


def xy(p):
    return (round(p.x, 6), round(p.y, 6))


def test_plans_candidates_comms_and_metrics(cli, tmp_path):
    """A spread trial (robots choose among goal candidates): each /robot<i>/candidates marks
    the goal the robot then heads for, each plan runs from the robot's pose to its goal (sent
    when the route changes), the radio's lines (sent when they change) are green where β was
    exchanged (CSP 1) and red where it dropped (CSP 0), and the metrics end at the trial's own."""
    args = ["run", "--map", "paper:5", "--start", "bottom-left", "--policy", "spread",
            "--seed", "4", "--json"]
    for csp in ["1", "0"]:
        bag = tmp_path / f"csp{csp}"
        out = subprocess.run([cli, *args, "--csp", csp, "--record", str(bag)], check=True,
                             capture_output=True, text=True)
        result = json.loads(out.stdout)
        topics = decoded(bag)
        for i in range(3):
            goals = {t: xy(m.pose.position) for t, m in topics[f"/robot{i}/goal_pose"]}
            poses = {t: xy(m.pose.position) for t, m in topics[f"/robot{i}/pose"]}
            chosen = 0
            for t, msg in topics[f"/robot{i}/candidates"]:
                assert msg.markers[0].action == 3  # DELETEALL: the last decision's markers go
                points = [xy(p) for p in msg.markers[1].points]
                assert 2 <= len(points) <= 8 and len(set(points)) == len(points)
                labels = [m for m in msg.markers if m.type == 9]
                assert [m.text for m in labels] == [str(k) for k in range(len(points))]
                pick = [m for m in msg.markers if m.type == 2]
                if pick and t in goals:
                    # A new goal is published with the decision that chose it.
                    assert xy(pick[0].pose.position) == goals[t] and goals[t] in points
                    chosen += 1
            assert chosen >= 3, f"robot {i}: {chosen} decisions with a new goal"
            last_goal = None
            for t, msg in sorted(topics[f"/robot{i}/goal_pose"] + topics[f"/robot{i}/plan"],
                                 key=lambda e: (e[0], e[1].__msgtype__ != "geometry_msgs/msg/PoseStamped")):
                if msg.__msgtype__ == "geometry_msgs/msg/PoseStamped":
                    last_goal = xy(msg.pose.position)
                    continue
                cells = [xy(p.pose.position) for p in msg.poses]
                assert cells[0] == poses[t], "a plan starts where the robot stands"
                if len(cells) > 1:
                    assert cells[-1] == last_goal, "and ends at its goal"
                    # One cell per step after the first, which may follow a slip (the agent
                    # re-plans from where it landed at its next timestep).
                    steps = [max(abs(a[0] - b[0]), abs(a[1] - b[1])) for a, b in zip(cells[1:], cells[2:])]
                    assert all(s == 1.0 for s in steps), "one cell per step"
            plans = [(t, [xy(p.pose.position) for p in m.poses]) for t, m in topics[f"/robot{i}/plan"]]
            assert all(b != a[len(a) - len(b):] or t in goals for (_, a), (t, b) in zip(plans, plans[1:])), \
                "a plan is published when the route or the goal changes, not as the robot advances along it"
            assert set(goals) <= {t for t, _ in plans}, "a new goal comes with its plan, reachable or not"
        comms = [m for _, m in topics["/comms"]]
        lines = [[[xy(p) for p in k.points] for k in m.markers] for m in comms]
        assert all(a != b for a, b in zip(lines, lines[1:])), "/comms when the lines change"
        # A colour without lines is removed (DELETE), never a LINE_LIST without points, which
        # Foxglove and Lichtblick flag as an error.
        assert all((k.action == 2) == (not k.points) for m in comms for k in m.markers)
        green = sum(len(m.markers[0].points) for m in comms)
        red = sum(len(m.markers[1].points) for m in comms)
        if csp == "1":
            assert green > 0 and red == 0
        else:
            assert green == 0 and red > 0
        explored = [m.data for _, m in topics["/metrics/explored"]]
        assert explored == sorted(explored) and explored[-1] == 1.0
        distance = topics["/metrics/distance"][-1][1].data
        assert abs(distance - result["metrics"]["ttd"]) < 1e-9


def test_a_goal_that_ends_shows_the_robots_own_cell(cli, tmp_path):
    """When a robot's goal becomes none (nothing left to reach), its /robot<i>/goal_pose moves
    to the cell it stands on, so the last goal does not stay shown (paper:10, spread, CSP 0:
    robot 2 loses its goal at timesteps 5 and 9)."""
    bag = tmp_path / "bag"
    out = subprocess.run([cli, "run", "--map", "paper:10", "--policy", "spread", "--csp", "0",
                          "--json", "--trajectory", "--record", str(bag)],
                         check=True, capture_output=True, text=True)
    steps = json.loads(out.stdout)["trajectory"]
    topics = decoded(bag)
    ended = [(b["t"], i) for a, b in zip(steps, steps[1:]) for i in range(len(b["goals"]))
             if a["goals"][i] is not None and b["goals"][i] is None]
    assert len(ended) >= 2, ended
    for t, i in ended:
        # Log times in nanoseconds of simulated time: timestep t is second t.
        goals = {s // 10**9: xy(m.pose.position) for s, m in topics[f"/robot{i}/goal_pose"]}
        poses = {s // 10**9: xy(m.pose.position) for s, m in topics[f"/robot{i}/pose"]}
        assert goals.get(t) == poses[t], f"robot {i} at timestep {t}"


def test_a_continuous_run_is_recorded(cli, tmp_path):
    """The continuous world's bag: every message decodes (rosbags, Jazzy); scans of 360 beams
    at the lidar's 5 Hz per robot, poses at 10 Hz with the robot's heading, fine maps at most
    every 5 s (slam_toolbox's map_update_interval), and the last explored share is the run's."""
    bag = tmp_path / "c"
    out = subprocess.run([cli, "run", "--world", "continuous", "--generate", "3", "--side", "12",
                          "--seed", "2", "--json", "--record", str(bag)],
                         check=True, capture_output=True, text=True)
    result = json.loads(out.stdout)
    topics = decoded(bag)
    poses = topics["/robot0/pose"]
    span = (poses[-1][0] - poses[0][0]) / 1e9
    assert abs(len(poses) - (10 * span + 1)) <= 1
    scans = topics["/robot0/scan"]
    assert all(len(m.ranges) == 360 for _, m in scans)
    assert abs(len(scans) - 5 * span) <= 2
    # At most one fine map every 5 s, the first with the first scan.
    times = [t for t, _ in topics["/robot0/map"]]
    assert times[0] == 0 and len(times) > 3
    assert all(b - a >= 5 * 10**9 - 10**6 for a, b in zip(times, times[1:]))
    headings = {round(m.pose.orientation.z, 3) for _, m in poses}
    assert len(headings) > 10, "the robot turns"
    # Every stamp once: the final state is not written again (tf2's TF_REPEATED_DATA).
    for topic in ["/clock", "/tf", "/robot0/pose", "/metrics/explored"]:
        stamps = [t for t, _ in topics[topic]]
        assert all(a < b for a, b in zip(stamps, stamps[1:])), topic
    # The final state is recorded whatever the rates: the last pose and metrics at the end.
    assert topics["/metrics/explored"][-1][0] == poses[-1][0] == topics["/clock"][-1][0]
    assert topics["/metrics/explored"][-1][1].data == 1.0 and result["complete"]
    # Every robot's first scan (the world scans all at the start) is in the bag.
    assert all(topics[f"/robot{i}/scan"][0][0] == 0 for i in range(3))
    # The true map twice, once: in 1 m cells and in the robots' fine pixels, covering the same
    # 12 m; the fine one has free and occupied pixels, no unknown.
    (_, coarse), = topics["/truth_map"]
    (_, fine), = topics["/fine_truth_map"]
    assert coarse.info.resolution == 1.0 and coarse.info.width == 12
    res = topics["/robot0/map"][0][1].info.resolution
    assert abs(fine.info.resolution - res) < 1e-6 and round(fine.info.width * res) == 12
    assert set(np.unique(fine.data)) == {0, 100}


def test_the_foxglove_layout_names_recorded_topics(cli, tmp_path):
    """docs/foxglove-layout.json: every panel it places exists, and every topic it shows (of
    robots 0–2) is one a recorded grid or continuous run carries."""
    layout = json.loads((Path(__file__).parents[4] / "docs" / "foxglove-layout.json").read_text())
    panels = layout["configById"]

    def placed(node):
        return [node] if isinstance(node, str) else placed(node["first"]) + placed(node["second"])

    assert sorted(placed(layout["layout"])) == sorted(panels)
    shown = set(panels["3D!madenet"]["topics"])
    shown |= {p["value"].split(".")[0] for k, c in panels.items() if k.startswith("Plot!")
              for p in c["paths"]}
    recorded = set()
    for world, name in [(["--map", "paper:2", "--policy", "spread"], "g"),
                        (["--world", "continuous", "--generate", "2", "--side", "10"], "c")]:
        subprocess.run([cli, "run", *world, "--record", str(tmp_path / name)], check=True,
                       capture_output=True)
        recorded |= set(decoded(tmp_path / name))
    wanted = {t for t in shown if not re.match(r"/robot[3-9]/", t)}
    assert wanted - recorded == set(), wanted - recorded


def launched_and_in_process(cli, tmp_path, args):
    """The decoded bags of one trial recorded by `launch` and by `run`."""
    for cmd, name in [("launch", "l"), ("run", "r")]:
        subprocess.run([cli, cmd, *args, "--record", str(tmp_path / name)], check=True,
                       capture_output=True)
    return decoded(tmp_path / "l"), decoded(tmp_path / "r")


def test_a_launched_run_records_what_the_in_process_run_records(cli, tmp_path):
    """`launch --record` (the world node records; the robots are processes over Zenoh): poses,
    goals, plans, the team map and the radio's lines are the in-process run's message for
    message; the robots' own maps stay in their processes (not recorded)."""
    launched, inproc = launched_and_in_process(
        cli, tmp_path, ["--map", "paper:3", "--policy", "spread", "--seed", "2", "--csp", "0.5"])
    assert not any(re.match(r"/robot\d/map$", t) for t in launched)
    same = ["/team_map", "/comms", "/tf", "/clock", "/truth_map", "/metrics/explored",
            "/metrics/distance"]
    same += [f"/robot{i}/{k}" for i in range(3) for k in ["pose", "goal_pose", "plan"]]
    for topic in same:
        a, b = launched[topic], inproc[topic]
        assert [t for t, _ in a] == [t for t, _ in b], topic
        assert [repr(m) for _, m in a] == [repr(m) for _, m in b], topic


def test_a_launched_learned_policy_shows_its_scores(cli, tmp_path):
    """With a learned policy, the launched run's candidate labels carry the scores the robots'
    processes weighed (sent in `Shown`): the same labels as the in-process run's."""
    launched, inproc = launched_and_in_process(
        cli, tmp_path, ["--map", "paper:3", "--policy", "made-net", "--seed", "2", "--csp", "1"])
    for i in range(3):
        labels = [[[k.text for k in m.markers if k.type == 9] for _, m in run[f"/robot{i}/candidates"]]
                  for run in (launched, inproc)]
        assert labels[0] == labels[1], f"robot {i}"
        assert any(":" in text for texts in labels[0] for text in texts), "labels carry scores"


def test_a_study_records_its_chosen_trials_as_they_ran(cli, tmp_path):
    """`compare`/`scale --record-trials`: each bag in OUT/bags/ is its trials.csv row's trial —
    the last /metrics/distance is the row's TTD, the last /metrics/explored its explored share,
    and the last /clock its TNS (grid) or ET (continuous) — decoded with rosbags (Jazzy)."""
    import csv

    runs = [
        ("grid", ["compare", "--methods", "nf,spread", "--oracles", "none", "--seeds", "1",
                  "--record-trials", "method=spread", "map=test_4|test_7", "csp=0|1"]),
        ("continuous", ["scale", "--world", "continuous", "--sides", "12", "--teams", "2",
                        "--seeds", "1", "--methods", "spread", "--record-trials", "seed=1"]),
    ]
    for world, args in runs:
        out = tmp_path / world
        subprocess.run([cli, *args[:1], "--out", str(out), *args[1:]], check=True,
                       capture_output=True)
        with open(out / "trials.csv") as f:
            rows = list(csv.DictReader(f))
        bags = sorted((out / "bags").iterdir())
        assert len(bags) == (16 if world == "grid" else 3)
        # The folder name of a row's trial (madenet_study::select::folder_name).
        by_name = {re.sub(r"[^A-Za-z0-9._-]", "-", "{method}_{map}_{start}_csp{csp}_seed{seed}"
                          .format(**r)): r for r in rows}
        for bag in bags:
            row = by_name[bag.name]
            topics = decoded(bag)
            assert abs(topics["/metrics/distance"][-1][1].data - float(row["ttd_m"])) < 1e-9
            assert abs(topics["/metrics/explored"][-1][1].data - float(row["explored"])) < 1e-12
            end = topics["/clock"][-1][1].clock
            seconds = end.sec + end.nanosec / 1e9
            if world == "grid":
                assert seconds == int(row["tns"]), bag.name
            else:
                assert abs(seconds - float(row["et_s"])) < 1e-6, bag.name


def test_a_learned_policy_labels_its_candidates_with_its_scores(cli, tmp_path):
    """`made-net-any` (conservative acting, spread margin 0.2 in its model.toml): each
    candidate's label carries the score the policy gave it at that decision (`k: 0.42`), and
    the chosen candidate scored at most the margin below the best — the acting rule, so the
    scores are the ones the decision weighed."""
    bag = tmp_path / "any"
    subprocess.run([cli, "run", "--map", "paper:3", "--policy", "made-net-any", "--seed", "1",
                    "--record", str(bag)], check=True, capture_output=True)
    topics = decoded(bag)
    decisions = 0
    for i in range(3):
        for _, msg in topics[f"/robot{i}/candidates"]:
            points = [xy(p) for p in msg.markers[1].points]
            labels = [m.text for m in msg.markers if m.type == 9]
            if len(points) == 1:
                assert labels == ["0"], "a decision without a choice weighs nothing"
                continue
            assert [t.split(": ")[0] for t in labels] == [str(k) for k in range(len(points))]
            scores = [float(t.split(": ")[1]) for t in labels]
            pick = [m for m in msg.markers if m.type == 2]
            assert len(pick) == 1
            chosen = points.index(xy(pick[0].pose.position))
            # Labels round to 0.01: allow that beside the margin.
            assert scores[chosen] >= max(scores) - 0.2 - 0.011, (labels, chosen)
            decisions += 1
    assert decisions >= 10


def test_a_map_with_an_origin_puts_every_topic_in_its_frame(cli, tmp_path):
    """A map whose origin is not (0, 0) (almost every real ROS map): the true maps at both
    resolutions, every robot's map and its poses are in that frame — the grids share the
    origin (and yaw), and every pose lies on the true map (issue 59: only /fine_truth_map had
    it, so viewers drew the scene away from the robots)."""
    import math
    w = h = 120  # 12 m at 0.1 m per pixel, a wall down the middle with a door
    px = bytearray([254]) * (w * h)
    for r in range(h):
        if not 50 <= r < 70:
            px[r * w + 60] = 0
    (tmp_path / "m.pgm").write_bytes(b"P5\n%d %d\n255\n" % (w, h) + bytes(px))
    origin = [-7.5, 3.25, 0.3]
    (tmp_path / "m.yaml").write_text(
        f"image: m.pgm\nresolution: 0.1\norigin: {origin}\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    bag = tmp_path / "o"
    subprocess.run([cli, "run", "--world", "continuous", "--map", str(tmp_path / "m.yaml"),
                    "--start", "0,0;0,1;1,0", "--seed", "1", "--json", "--record", str(bag)],
                   check=True, capture_output=True, text=True)
    topics = decoded(bag)
    grids = [topics["/truth_map"][0][1], topics["/fine_truth_map"][0][1]]
    grids += [m for t in topics if t.startswith("/robot") and t.endswith("/map")
              for _, m in topics[t][:1]]
    assert len(grids) >= 3
    for g in grids:
        o = g.info.origin
        yaw = 2 * math.atan2(o.orientation.z, o.orientation.w)
        assert abs(o.position.x - origin[0]) < 1e-6 and abs(o.position.y - origin[1]) < 1e-6, o
        assert abs(yaw - origin[2]) < 1e-6
    # Every pose, taken back into the grid's own axes, lies on the 12 m map.
    c, s = math.cos(origin[2]), math.sin(origin[2])
    for t in [t for t in topics if t.endswith("/pose")]:
        for _, m in topics[t]:
            dx, dy = m.pose.position.x - origin[0], m.pose.position.y - origin[1]
            lx, ly = c * dx + s * dy, -s * dx + c * dy
            assert 0 <= lx <= 12 and 0 <= ly <= 12, (t, lx, ly)
