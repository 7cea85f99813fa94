"""`madenet explore` against a nav2 stand-in written here with ``eclipse-zenoh`` and ``rosbags``
only (no madenet code): the stand-in publishes a map that grows as its robot looks around,
the robot's pose as TF and a fast ``/clock``, and serves ``navigate_to_pose`` — aborting
every third goal. The node must recover from the aborts and explore both rooms to the end.
"""

import math
import os
import subprocess
import time
import uuid

import numpy as np
import pytest
import zenoh

from test_ros2_wire import action_server, attachment, cdr, free_port, key, read_attachment, ts  # noqa: F401

CLI = os.environ.get("MADENET_CLI")
pytestmark = pytest.mark.skipif(not CLI, reason="MADENET_CLI is not set")

RES = 0.1  # metres per pixel
# Two 4 m × 5 m rooms side by side, a 1 m door in the wall between them (pixels: rows from
# the origin up, as OccupancyGrid rows are).
W, H = 90, 50
SIM_RATE = 10.0  # simulated seconds per wall second (the node follows /clock)
RANGE = 3.0  # metres the robot sees


def truth():
    occ = np.zeros((H, W), dtype=bool)
    occ[0, :] = occ[-1, :] = True
    occ[:, 0] = occ[:, -1] = True
    occ[:, 44:46] = True
    occ[20:30, 44:46] = False  # the door
    return occ


def visible(occ, x, y):
    """Pixels within RANGE of (x, y) metres with a clear line from it."""
    seen = np.zeros_like(occ)
    r0, c0 = int(y / RES), int(x / RES)
    n = int(RANGE / RES)
    for r in range(max(0, r0 - n), min(H, r0 + n + 1)):
        for c in range(max(0, c0 - n), min(W, c0 + n + 1)):
            if (r - r0) ** 2 + (c - c0) ** 2 > n * n:
                continue
            steps = max(abs(r - r0), abs(c - c0), 1)
            for k in range(1, steps + 1):
                rr = r0 + round((r - r0) * k / steps)
                cc = c0 + round((c - c0) * k / steps)
                if (rr, cc) == (r, c):
                    seen[r, c] = True
                    break
                if occ[rr, cc]:
                    break
    return seen


@pytest.mark.parametrize("policy,remapped", [("explore-lite", False), ("spread", False), ("explore-lite", True)])
def test_the_node_recovers_from_a_stand_in_s_aborts_and_explores_both_rooms(ts, tmp_path, policy, remapped):
    """Remapped: the stand-in publishes its map on `slam/map` and serves `nav/navigate_to_pose`;
    the node finds them only through `-r map:=slam/map -r navigate_to_pose:=nav/navigate_to_pose`."""
    port = free_port()
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("listen/endpoints", f'["tcp/127.0.0.1:{port}"]')
    conf.insert_json5("scouting/multicast/enabled", "false")
    session = zenoh.open(conf)
    act = "nav2_msgs/action/NavigateToPose"
    T = ts.types
    Time = T["builtin_interfaces/msg/Time"]
    Header = T["std_msgs/msg/Header"]
    gid = uuid.uuid4().bytes
    occ = truth()
    known = np.full((H, W), -1, dtype=np.int8)
    pose = [2.0, 2.5]  # the robot, in room A

    def stamp(sim):
        return Time(sec=int(sim), nanosec=int((sim % 1) * 1e9))

    def look():
        seen = visible(occ, *pose)
        known[seen] = np.where(occ[seen], 100, 0).astype(np.int8)

    map_name = "robot0/slam/map" if remapped else "robot0/map"
    action = "robot0/nav/navigate_to_pose" if remapped else "robot0/navigate_to_pose"
    map_pub = session.declare_publisher(key(ts, map_name, "nav_msgs/msg/OccupancyGrid"))
    tf_pub = session.declare_publisher(key(ts, "robot0/tf", "tf2_msgs/msg/TFMessage"))
    clock_pub = session.declare_publisher(key(ts, "clock", "rosgraph_msgs/msg/Clock"))
    queryables, tokens = action_server(session, ts, "robot0/bt_navigator", action, act)

    def publish(sim, seq):
        s = stamp(sim)
        clock_pub.put(cdr(ts, T["rosgraph_msgs/msg/Clock"](clock=s), "rosgraph_msgs/msg/Clock"), attachment=attachment(seq, gid))
        Vec = T["geometry_msgs/msg/Vector3"]
        Quat = T["geometry_msgs/msg/Quaternion"]
        tf = T["geometry_msgs/msg/TransformStamped"](
            header=Header(stamp=s, frame_id="map"),
            child_frame_id="base_link",
            transform=T["geometry_msgs/msg/Transform"](
                translation=Vec(x=pose[0], y=pose[1], z=0.0), rotation=Quat(x=0.0, y=0.0, z=0.0, w=1.0)
            ),
        )
        tf_pub.put(cdr(ts, T["tf2_msgs/msg/TFMessage"](transforms=[tf]), "tf2_msgs/msg/TFMessage"), attachment=attachment(seq, gid))
        Point = T["geometry_msgs/msg/Point"]
        info = T["nav_msgs/msg/MapMetaData"](
            map_load_time=s,
            resolution=RES,
            width=W,
            height=H,
            origin=T["geometry_msgs/msg/Pose"](position=Point(x=0.0, y=0.0, z=0.0), orientation=Quat(x=0.0, y=0.0, z=0.0, w=1.0)),
        )
        grid = T["nav_msgs/msg/OccupancyGrid"](header=Header(stamp=s, frame_id="map"), info=info, data=known.reshape(-1).copy())
        map_pub.put(cdr(ts, grid, "nav_msgs/msg/OccupancyGrid"), attachment=attachment(seq, gid))

    params = tmp_path / "explore.yaml"
    params.write_text(
        "/**:\n  ros__parameters:\n    costmap_topic: map\n    costmap_updates_topic: map_updates\n"
        "    planner_frequency: 1.0\n    progress_timeout: 30.0\n    potential_scale: 3.0\n"
        f"    min_frontier_size: 0.3\n    use_sim_time: true\n    policy: {policy}\n"
    )
    remaps = ["-r", "map:=slam/map", "-r", "navigate_to_pose:=nav/navigate_to_pose"] if remapped else []
    node = subprocess.Popen(
        [CLI, "explore", "--params-file", str(params), "--namespace", "/robot0", "--ros2", f"tcp/127.0.0.1:{port}", *remaps],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    started = time.time()
    goals = {}  # goal id → [x, y, end time, status, error code, ended]
    active = None  # the goal under way
    waiting = []  # get_result queries not answered yet
    counts = {"sent": 0, "aborted": 0, "succeeded": 0, "preempted": 0}
    seq = 0
    farthest = pose[0]
    look()
    try:
        while node.poll() is None and time.time() - started < 240:
            sim = (time.time() - started) * SIM_RATE
            seq += 1
            publish(sim, seq)
            while (q := queryables["send_goal"].try_recv()) is not None:
                qseq, _, qgid = read_attachment(bytes(q.attachment.to_bytes()))
                req = ts.deserialize_cdr(bytes(q.payload.to_bytes()), f"{act}_SendGoal_Request")
                p = req.goal.pose.pose.position
                assert req.goal.pose.header.frame_id == "map"
                assert 0 <= p.x < W * RES and 0 <= p.y < H * RES, (p.x, p.y)  # never off the map
                counts["sent"] += 1
                if active is not None and not goals[active][5]:
                    # A new goal preempts the one under way: nav2 aborts it (no error code).
                    goals[active][2:6] = [sim, 6, 0, True]
                    counts["preempted"] += 1
                # Each goal ends 2 simulated seconds later: every third aborted halfway.
                aborted = counts["sent"] % 3 == 0
                active = bytes(req.goal_id.uuid)
                goals[active] = [p.x, p.y, sim + 2.0, 6 if aborted else 4, 9000 if aborted else 0, False]
                resp = T[f"{act}_SendGoal_Response"](accepted=True, stamp=stamp(sim))
                q.reply(q.key_expr, cdr(ts, resp, f"{act}_SendGoal_Response"), attachment=attachment(qseq, qgid))
                q.drop()
            while (q := queryables["get_result"].try_recv()) is not None:
                waiting.append(q)
            while (q := queryables["cancel_goal"].try_recv()) is not None:
                qseq, _, qgid = read_attachment(bytes(q.attachment.to_bytes()))
                req = ts.deserialize_cdr(bytes(q.payload.to_bytes()), "action_msgs/srv/CancelGoal_Request")
                g = goals.get(bytes(req.goal_info.goal_id.uuid))
                if g is not None and not g[5]:
                    g[2:6] = [sim, 5, 0, True]
                resp = T["action_msgs/srv/CancelGoal_Response"](return_code=0, goals_canceling=[])
                q.reply(q.key_expr, cdr(ts, resp, "action_msgs/srv/CancelGoal_Response"), attachment=attachment(qseq, qgid))
                q.drop()
            # The goal under way ends: the robot gets there (or halfway, aborted) and looks.
            g = goals.get(active)
            if g is not None and not g[5] and sim >= g[2]:
                g[5] = True
                frac = 1.0 if g[3] == 4 else 0.5
                tx, ty = pose[0] + frac * (g[0] - pose[0]), pose[1] + frac * (g[1] - pose[1])
                if not occ[int(ty / RES), int(tx / RES)]:
                    pose[0], pose[1] = tx, ty
                    farthest = max(farthest, tx)
                    look()
                counts["succeeded" if g[3] == 4 else "aborted"] += 1
            still = []
            for q in waiting:
                qseq, _, qgid = read_attachment(bytes(q.attachment.to_bytes()))
                req = ts.deserialize_cdr(bytes(q.payload.to_bytes()), f"{act}_GetResult_Request")
                g = goals.get(bytes(req.goal_id.uuid))
                if g is None or not g[5]:
                    still.append(q)
                    continue
                Res = T[f"{act}_Result"](error_code=g[4], error_msg="stand-in abort" if g[4] else "")
                resp = T[f"{act}_GetResult_Response"](status=g[3], result=Res)
                q.reply(q.key_expr, cdr(ts, resp, f"{act}_GetResult_Response"), attachment=attachment(qseq, qgid))
                q.drop()
            waiting = still
            time.sleep(0.02)
        out, err = node.communicate(timeout=30) if node.poll() is not None else ("", "")
        assert node.returncode == 0, (node.returncode, out, err[-3000:])
        assert "complete: no frontier left" in out, (out, err[-3000:])
        assert counts["aborted"] >= 1 and counts["succeeded"] >= 1, counts
        free = ~occ
        coverage = ((known >= 0) & free).sum() / free.sum()
        assert coverage >= 0.95, (coverage, counts, out)
        assert farthest > 4.6, ("the robot never went through the door", farthest)
        print(counts, f"coverage {coverage:.3f}", out)
    finally:
        if node.poll() is None:
            node.kill()
        for t in tokens:
            t.undeclare()
        session.close()
