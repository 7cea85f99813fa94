"""`madenet run --record`: the bag read by readers nobody here wrote — the `mcap` package with
`mcap-ros2-support`, and `rosbags` with its ROS 2 Jazzy typestore."""

import json
import subprocess
from pathlib import Path

import numpy as np
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

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


def test_the_same_seed_gives_the_same_bytes(cli, tmp_path):
    record(cli, tmp_path / "a")
    record(cli, tmp_path / "b")
    assert (tmp_path / "a/a_0.mcap").read_bytes() == (tmp_path / "b/b_0.mcap").read_bytes()
    meta = lambda p: (tmp_path / p / "metadata.yaml").read_text().replace(f"{p}_0.mcap", "X")
    assert meta("a") == meta("b")
