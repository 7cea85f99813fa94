"""madenet's ROS 2 services, actions and type hashes, checked by code nobody here wrote.

The Python ``eclipse-zenoh`` package carries the bytes; ``rosbags`` computes the type hashes
(REP 2011) and writes and reads the CDR. Nothing here imports madenet: the other side is the
``ros2_wire`` example of ``madenet-ros2`` (its path in ``MADENET_ROS2_WIRE``), a separate
process that this test talks to over zenoh on loopback, as a ROS 2 node with rmw_zenoh would.
"""

import os
import socket
import struct
import subprocess
import time
import uuid

import numpy as np
import pytest
import zenoh

from rihs01 import add, add_action, add_service, store

WIRE = os.environ.get("MADENET_ROS2_WIRE")
pytestmark = pytest.mark.skipif(not WIRE, reason="MADENET_ROS2_WIRE is not set")

NAV2_FEEDBACK = """geometry_msgs/PoseStamped current_pose
builtin_interfaces/Duration navigation_time
builtin_interfaces/Duration estimated_time_remaining
int16 number_of_recoveries
float32 distance_remaining
"""


@pytest.fixture(scope="module")
def ts():
    """A Jazzy type store with the service and action types madenet speaks."""
    t = store()
    add_service(t, "example_interfaces/srv/AddTwoInts", "int64 a\nint64 b\n", "int64 sum\n")
    add_service(
        t,
        "action_msgs/srv/CancelGoal",
        "action_msgs/GoalInfo goal_info\n",
        "int8 return_code\naction_msgs/GoalInfo[] goals_canceling\n",
    )
    add_action(t, "example_interfaces/action/Fibonacci", "int32 order\n", "int32[] sequence\n", "int32[] sequence\n")
    add_action(
        t,
        "nav2_msgs/action/NavigateToPose",
        "geometry_msgs/PoseStamped pose\nstring behavior_tree\n",
        "uint16 error_code\nstring error_msg\n",
        NAV2_FEEDBACK,
    )
    add(
        t,
        "std_msgs/Header header\nint32 x\nint32 y\nuint32 width\nuint32 height\nint8[] data\n",
        "map_msgs/msg/OccupancyGridUpdate",
    )
    return t


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture()
def peer():
    """A zenoh peer listening on loopback; madenet's side connects to it."""
    port = free_port()
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("listen/endpoints", f'["tcp/127.0.0.1:{port}"]')
    conf.insert_json5("scouting/multicast/enabled", "false")
    session = zenoh.open(conf)
    yield session, f"tcp/127.0.0.1:{port}"
    session.close()


def dds(name):
    pkg, kind, short = name.split("/")
    return f"{pkg}::{kind}::dds_::{short}_"


def key(ts, name, typ):
    return f"0/{name.strip('/')}/{dds(typ)}/{ts.hash_rihs01(typ)}"


def action_server(session, ts, node, action, act, qos="::,10:,:,:,,"):
    """An action server as rmw_zenoh declares one: for each of its three services a liveliness
    token of node `node` ("ns/name", no leading slash) and a queryable on `action` (the action's
    name); `act` is the action type. Returns the queryables by part and the tokens (keep them)."""
    ns, name = node.rsplit("/", 1) if "/" in node else ("", node)
    tokens, queryables = [], {}
    for part, typ in [
        ("send_goal", f"{act}_SendGoal"),
        ("get_result", f"{act}_GetResult"),
        ("cancel_goal", "action_msgs/srv/CancelGoal"),
    ]:
        tokens.append(
            session.liveliness().declare_token(
                f"@ros2_lv/0/{session.zid()}/0/{len(tokens) + 1}/SS/%/%{ns}/{name}/"
                f"%{action.replace('/', '%')}%_action%{part}/{dds(typ)}/{ts.hash_rihs01(typ)}/{qos}"
            )
        )
        queryables[part] = session.declare_queryable(key(ts, f"{action}/_action/{part}", typ), complete=True)
    return queryables, tokens


def attachment(seq, gid):
    """rmw_zenoh's attachment: i64 sequence number, i64 ns, then the 16-byte GID with its length."""
    return struct.pack("<qq", seq, time.time_ns()) + bytes([16]) + gid


def read_attachment(raw):
    assert len(raw) == 33, raw
    seq, ns = struct.unpack("<qq", raw[:16])
    assert raw[16] == 16
    return seq, ns, raw[17:]


def cdr(ts, msg, typ):
    return bytes(ts.serialize_cdr(msg, typ))


def spawn(*args):
    p = subprocess.Popen([WIRE, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    return p


def wait_ready(p):
    line = p.stdout.readline()
    assert line.strip() == "ready", (line, p.stderr.read() if p.poll() is not None else "")


def wait_token(session, pattern, timeout=20.0):
    deadline = time.time() + timeout
    while time.time() < deadline:
        if any(r.ok is not None for r in session.liveliness().get(pattern, timeout=1.0)):
            return
        time.sleep(0.05)
    raise AssertionError(f"no liveliness token matches {pattern}")


def query(session, k, payload, seq, gid, timeout=20.0):
    replies = list(
        session.get(
            k,
            payload=payload,
            attachment=attachment(seq, gid),
            target=zenoh.QueryTarget.ALL_COMPLETE,
            timeout=timeout,
        )
    )
    assert len(replies) == 1, replies
    return replies[0]


def test_type_hashes_match_an_independent_computation(ts):
    out = subprocess.run([WIRE, "hashes"], capture_output=True, text=True, check=True).stdout
    ours = dict(line.split() for line in out.splitlines())
    checked = 0
    for name, h in ours.items():
        if name in ts.fielddefs:
            assert h == ts.hash_rihs01(name), name
            checked += 1
    for must in [
        "std_msgs/msg/String",
        "example_interfaces/srv/AddTwoInts",
        "action_msgs/srv/CancelGoal",
        "action_msgs/msg/GoalStatusArray",
        "unique_identifier_msgs/msg/UUID",
        "nav2_msgs/action/NavigateToPose_SendGoal",
        "nav2_msgs/action/NavigateToPose_GetResult",
        "nav2_msgs/action/NavigateToPose_FeedbackMessage",
        "tf2_msgs/msg/TFMessage",
        "map_msgs/msg/OccupancyGridUpdate",
    ]:
        assert must in ours and must in ts.fielddefs, must
    assert checked >= 30, checked
    # rmw_zenoh's design document prints these two.
    assert ours["std_msgs/msg/String"].startswith("RIHS01_df668c740482bbd48fb39d76a70dfd4b")
    assert ours["example_interfaces/srv/AddTwoInts"].startswith("RIHS01_e118de6bf5eeb66a2491b5bda11202e7")


def test_a_python_client_calls_a_madenet_server(ts, peer):
    session, endpoint = peer
    p = spawn("serve-add", endpoint, "2")
    try:
        wait_ready(p)
        typ = "example_interfaces/srv/AddTwoInts"
        wait_token(session, f"@ros2_lv/0/*/*/*/SS/%/%/adder/%add_two_ints/{dds(typ)}/{ts.hash_rihs01(typ)}/*")
        k = key(ts, "add_two_ints", typ)
        Req = ts.types[f"{typ}_Request"]
        gid = uuid.uuid4().bytes
        # A malformed request first: an error reply, and the server keeps count and goes on.
        reply = query(session, k, b"\x00\x01\x00\x00\x07", 4, gid)
        assert reply.err is not None
        for seq, (a, b) in enumerate([(2, 3), (-40, -2)], start=5):
            reply = query(session, k, cdr(ts, Req(a=a, b=b), f"{typ}_Request"), seq, gid)
            assert reply.ok is not None, reply.err
            got_seq, _, got_gid = read_attachment(bytes(reply.ok.attachment.to_bytes()))
            assert (got_seq, got_gid) == (seq, gid)
            resp = ts.deserialize_cdr(bytes(reply.ok.payload.to_bytes()), f"{typ}_Response")
            assert resp.sum == a + b
        out, err = p.communicate(timeout=30)
        assert p.returncode == 0, err
        assert "refused 1" in out
    finally:
        p.kill()


def test_a_madenet_client_calls_a_python_server(ts, peer):
    session, endpoint = peer
    typ = "example_interfaces/srv/AddTwoInts"
    qos = "::,10:,:,:,,"
    token = session.liveliness().declare_token(
        f"@ros2_lv/0/{session.zid()}/0/1/SS/%/%/py_adder/%add_two_ints/{dds(typ)}/{ts.hash_rihs01(typ)}/{qos}"
    )
    queryable = session.declare_queryable(key(ts, "add_two_ints", typ), complete=True)
    p = spawn("call-add", endpoint, "20", "22")
    try:
        q = queryable.recv()
        seq, _, gid = read_attachment(bytes(q.attachment.to_bytes()))
        req = ts.deserialize_cdr(bytes(q.payload.to_bytes()), f"{typ}_Request")
        Resp = ts.types[f"{typ}_Response"]
        q.reply(q.key_expr, cdr(ts, Resp(sum=req.a + req.b), f"{typ}_Response"), attachment=attachment(seq, gid))
        q.drop()
        out, err = p.communicate(timeout=30)
        assert p.returncode == 0, err
        assert out.strip() == "sum 42"
    finally:
        p.kill()
        token.undeclare()


def test_a_python_action_client_drives_a_madenet_action_server(ts, peer):
    session, endpoint = peer
    act = "example_interfaces/action/Fibonacci"
    p = spawn("serve-fib", endpoint, "2")
    try:
        wait_ready(p)
        send = key(ts, "fibonacci/_action/send_goal", f"{act}_SendGoal")
        result = key(ts, "fibonacci/_action/get_result", f"{act}_GetResult")
        cancel = key(ts, "fibonacci/_action/cancel_goal", "action_msgs/srv/CancelGoal")
        feedback = key(ts, "fibonacci/_action/feedback", f"{act}_FeedbackMessage")
        wait_token(session, f"@ros2_lv/0/*/*/*/SS/%/%/fib_server/%fibonacci%_action%send_goal/**")
        feedbacks = session.declare_subscriber(feedback)
        gid = uuid.uuid4().bytes
        UUID = ts.types["unique_identifier_msgs/msg/UUID"]
        Goal = ts.types[f"{act}_Goal"]
        SendReq = ts.types[f"{act}_SendGoal_Request"]
        ResReq = ts.types[f"{act}_GetResult_Request"]

        def send_goal(order, seq):
            gid_ = UUID(uuid=np.frombuffer(uuid.uuid4().bytes, dtype=np.uint8))
            r = query(session, send, cdr(ts, SendReq(goal_id=gid_, goal=Goal(order=order)), f"{act}_SendGoal_Request"), seq, gid)
            assert r.ok is not None, r.err
            assert ts.deserialize_cdr(bytes(r.ok.payload.to_bytes()), f"{act}_SendGoal_Response").accepted
            return gid_

        first = send_goal(5, 1)
        r = query(session, result, cdr(ts, ResReq(goal_id=first), f"{act}_GetResult_Request"), 2, gid, timeout=60)
        res = ts.deserialize_cdr(bytes(r.ok.payload.to_bytes()), f"{act}_GetResult_Response")
        assert res.status == 4 and list(res.result.sequence) == [0, 1, 1, 2, 3, 5]
        fb = ts.deserialize_cdr(bytes(feedbacks.recv().payload.to_bytes()), f"{act}_FeedbackMessage")
        assert bytes(fb.goal_id.uuid) == bytes(first.uuid)

        second = send_goal(10_000, 3)
        GoalInfo = ts.types["action_msgs/msg/GoalInfo"]
        Time = ts.types["builtin_interfaces/msg/Time"]
        CancelReq = ts.types["action_msgs/srv/CancelGoal_Request"]
        r = query(session, cancel, cdr(ts, CancelReq(goal_info=GoalInfo(goal_id=second, stamp=Time(sec=0, nanosec=0))), "action_msgs/srv/CancelGoal_Request"), 4, gid)
        ans = ts.deserialize_cdr(bytes(r.ok.payload.to_bytes()), "action_msgs/srv/CancelGoal_Response")
        assert ans.return_code == 0 and len(ans.goals_canceling) == 1
        r = query(session, result, cdr(ts, ResReq(goal_id=second), f"{act}_GetResult_Request"), 5, gid, timeout=60)
        assert ts.deserialize_cdr(bytes(r.ok.payload.to_bytes()), f"{act}_GetResult_Response").status == 5
        out, err = p.communicate(timeout=30)
        assert p.returncode == 0, err
    finally:
        p.kill()


def test_a_python_action_server_answers_madenet_s_action_client(ts, peer):
    session, endpoint = peer
    act = "example_interfaces/action/Fibonacci"
    queryables, tokens = action_server(session, ts, "py_fib", "fibonacci", act)
    feedback = session.declare_publisher(key(ts, "fibonacci/_action/feedback", f"{act}_FeedbackMessage"))
    p = spawn("send-fib", endpoint, "4")
    try:
        q = queryables["send_goal"].recv()
        seq, _, gid = read_attachment(bytes(q.attachment.to_bytes()))
        req = ts.deserialize_cdr(bytes(q.payload.to_bytes()), f"{act}_SendGoal_Request")
        Time = ts.types["builtin_interfaces/msg/Time"]
        Resp = ts.types[f"{act}_SendGoal_Response"]
        q.reply(q.key_expr, cdr(ts, Resp(accepted=True, stamp=Time(sec=1, nanosec=2)), f"{act}_SendGoal_Response"), attachment=attachment(seq, gid))
        q.drop()
        r = queryables["get_result"].recv()
        rseq, _, rgid = read_attachment(bytes(r.attachment.to_bytes()))
        asked = ts.deserialize_cdr(bytes(r.payload.to_bytes()), f"{act}_GetResult_Request")
        assert bytes(asked.goal_id.uuid) == bytes(req.goal_id.uuid)
        seqs = [0, 1]
        Fb = ts.types[f"{act}_Feedback"]
        FbMsg = ts.types[f"{act}_FeedbackMessage"]
        while len(seqs) <= req.goal.order:
            seqs.append(seqs[-1] + seqs[-2])
            msg = FbMsg(goal_id=req.goal_id, feedback=Fb(sequence=np.array(seqs, dtype=np.int32)))
            feedback.put(cdr(ts, msg, f"{act}_FeedbackMessage"), attachment=attachment(len(seqs), gid))
            time.sleep(0.05)
        Res = ts.types[f"{act}_Result"]
        GR = ts.types[f"{act}_GetResult_Response"]
        r.reply(r.key_expr, cdr(ts, GR(status=4, result=Res(sequence=np.array(seqs, dtype=np.int32))), f"{act}_GetResult_Response"), attachment=attachment(rseq, rgid))
        r.drop()
        out, err = p.communicate(timeout=30)
        assert p.returncode == 0, err
        assert out.strip().splitlines()[-1] == "status 4 sequence [0, 1, 1, 2, 3]", out
        assert "feedback" in out
    finally:
        p.kill()
        for t in tokens:
            t.undeclare()


def test_a_python_client_drives_a_simulated_nav2_robot(ts, peer):
    """NavigateToPose as nav2 users send it: 20 goals on a generated floor plan reached with
    feedback; a goal off the map aborted with nav2's GOAL_OUTSIDE_MAP (204); a NaN pose
    rejected; a malformed request answered with an error; one goal canceled under way."""
    session, endpoint = peer
    act = "nav2_msgs/action/NavigateToPose"
    p = subprocess.Popen(
        [WIRE, "nav2-sim", endpoint, "1"], stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        goals = []
        for _ in range(20):
            word, x, y = p.stdout.readline().split()
            assert word == "goal"
            goals.append((float(x), float(y)))
        ns = "robot0/navigate_to_pose/_action"
        send = key(ts, f"{ns}/send_goal", f"{act}_SendGoal")
        result = key(ts, f"{ns}/get_result", f"{act}_GetResult")
        cancel = key(ts, f"{ns}/cancel_goal", "action_msgs/srv/CancelGoal")
        feedback = key(ts, f"{ns}/feedback", f"{act}_FeedbackMessage")
        wait_token(session, "@ros2_lv/0/*/*/*/SS/%/%robot0/bt_navigator/%robot0%navigate_to_pose%_action%send_goal/**")
        # A ring: feedback not read while waiting for a result is dropped, oldest first.
        feedbacks = session.declare_subscriber(feedback, zenoh.handlers.RingChannel(8))
        gid = uuid.uuid4().bytes
        UUID = ts.types["unique_identifier_msgs/msg/UUID"]
        Goal = ts.types[f"{act}_Goal"]
        SendReq = ts.types[f"{act}_SendGoal_Request"]
        ResReq = ts.types[f"{act}_GetResult_Request"]
        Header = ts.types["std_msgs/msg/Header"]
        Time = ts.types["builtin_interfaces/msg/Time"]
        PoseStamped = ts.types["geometry_msgs/msg/PoseStamped"]
        Pose = ts.types["geometry_msgs/msg/Pose"]
        Point = ts.types["geometry_msgs/msg/Point"]
        Quaternion = ts.types["geometry_msgs/msg/Quaternion"]

        def send_goal(x, y, seq, accepted=True):
            goal_id = UUID(uuid=np.frombuffer(uuid.uuid4().bytes, dtype=np.uint8))
            pose = PoseStamped(
                header=Header(stamp=Time(sec=0, nanosec=0), frame_id="map"),
                pose=Pose(position=Point(x=x, y=y, z=0.0), orientation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)),
            )
            req = SendReq(goal_id=goal_id, goal=Goal(pose=pose, behavior_tree=""))
            r = query(session, send, cdr(ts, req, f"{act}_SendGoal_Request"), seq, gid)
            assert r.ok is not None, r.err
            answer = ts.deserialize_cdr(bytes(r.ok.payload.to_bytes()), f"{act}_SendGoal_Response")
            assert answer.accepted == accepted, (x, y)
            return goal_id

        def result_of(goal_id, seq):
            r = query(session, result, cdr(ts, ResReq(goal_id=goal_id), f"{act}_GetResult_Request"), seq, gid, timeout=120)
            assert r.ok is not None, (bytes(r.err.payload.to_bytes()), p.poll())
            return ts.deserialize_cdr(bytes(r.ok.payload.to_bytes()), f"{act}_GetResult_Response")

        # Twenty goals reached, with feedback on the way.
        for seq, (x, y) in enumerate(goals, start=1):
            goal_id = send_goal(x + 0.2, y - 0.1, 10 * seq)
            res = result_of(goal_id, 10 * seq + 1)
            assert (res.status, res.result.error_code) == (4, 0), (seq, x, y, res)
        fb = ts.deserialize_cdr(bytes(feedbacks.recv().payload.to_bytes()), f"{act}_FeedbackMessage")
        assert fb.feedback.current_pose.header.frame_id == "map"
        assert fb.feedback.distance_remaining >= 0.0
        # Off the map: aborted with the planner's code. A NaN pose: rejected. A malformed
        # request: an error reply.
        res = result_of(send_goal(-50.0, 3.0, 300), 301)
        assert (res.status, res.result.error_code) == (6, 204), res
        send_goal(float("nan"), 1.0, 302, accepted=False)
        bad = query(session, send, b"\x00\x01\x00\x00\x07", 303, gid)
        assert bad.err is not None
        # One more, canceled once it is under way.
        last = goals[-1]
        far = max(goals, key=lambda g: abs(g[0] - last[0]) + abs(g[1] - last[1]))
        goal_id = send_goal(far[0], far[1], 400)
        while True:
            fb = ts.deserialize_cdr(bytes(feedbacks.recv().payload.to_bytes()), f"{act}_FeedbackMessage")
            if bytes(fb.goal_id.uuid) == bytes(goal_id.uuid):
                break
        GoalInfo = ts.types["action_msgs/msg/GoalInfo"]
        CancelReq = ts.types["action_msgs/srv/CancelGoal_Request"]
        req = CancelReq(goal_info=GoalInfo(goal_id=goal_id, stamp=Time(sec=0, nanosec=0)))
        r = query(session, cancel, cdr(ts, req, "action_msgs/srv/CancelGoal_Request"), 401, gid)
        ans = ts.deserialize_cdr(bytes(r.ok.payload.to_bytes()), "action_msgs/srv/CancelGoal_Response")
        assert ans.return_code == 0 and len(ans.goals_canceling) == 1
        assert result_of(goal_id, 402).status == 5
        out, err = p.communicate(input="", timeout=30)
        assert p.returncode == 0, err
        assert "outcomes " + "4:0 " * 20 + "6:204 5:0" in out, out
        assert "rejected 1" in out, out
        assert "refused 1" in out, out
        assert "collisions 0" in out, out
    finally:
        p.kill()
