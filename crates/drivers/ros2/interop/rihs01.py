"""Type hashes (REP 2011) computed by the rosbags package, for test_ros2_wire.py.

rosbags' Jazzy store keeps service_msgs/msg/ServiceEventInfo.client_gid as char[16];
rosidl maps char to uint8, so the field is corrected here, or every service hash is wrong.
get_types_from_msg names srv/action parts pkg/srv/msg/Name; the names are put right.
Services and actions are registered as rosidl generates them: a service is its request,
response and event messages together; an action is its goal, result and feedback, the
SendGoal and GetResult services, and the FeedbackMessage.
"""

from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Nodetype


def _fixname(x):
    if isinstance(x, str):
        for kind in ("srv", "action"):
            x = x.replace(f"/{kind}/msg/", f"/{kind}/")
        return x
    if isinstance(x, tuple):
        return tuple(_fixname(e) for e in x)
    if isinstance(x, list):
        return [_fixname(e) for e in x]
    return x


def store():
    """rosbags' Jazzy type store, with ServiceEventInfo.client_gid as rosidl has it."""
    jazzy = get_typestore(Stores.ROS2_JAZZY)
    ts = get_typestore(Stores.EMPTY)
    defs = dict(jazzy.fielddefs)
    consts, fields = defs["service_msgs/msg/ServiceEventInfo"]
    gid = (Nodetype.ARRAY, ((Nodetype.BASE, ("uint8", 0)), 16))
    fields = [(n, gid if n == "client_gid" else t) for n, t in fields]
    defs["service_msgs/msg/ServiceEventInfo"] = (consts, fields)
    ts.register(defs)
    return ts


def add(ts, text, name):
    """Registers the message `name` with the .msg `text`."""
    types = {_fixname(k): _fixname(v) for k, v in get_types_from_msg(text, name).items()}
    ts.register(types)


def add_service(ts, name, req, resp):
    """Registers the service `name` (`pkg/srv/Name`) with its request and response fields."""
    add(ts, req, f"{name}_Request")
    add(ts, resp, f"{name}_Response")
    add(
        ts,
        f"service_msgs/ServiceEventInfo info\n{name}_Request[<=1] request\n{name}_Response[<=1] response\n",
        f"{name}_Event",
    )
    add(ts, f"{name}_Request request_message\n{name}_Response response_message\n{name}_Event event_message\n", name)


def add_action(ts, name, goal, result, feedback):
    """Registers the action `name` (`pkg/action/Name`) and the types rosidl derives from it."""
    add(ts, goal, f"{name}_Goal")
    add(ts, result, f"{name}_Result")
    add(ts, feedback, f"{name}_Feedback")
    add_service(
        ts,
        f"{name}_SendGoal",
        f"unique_identifier_msgs/UUID goal_id\n{name}_Goal goal\n",
        "bool accepted\nbuiltin_interfaces/Time stamp\n",
    )
    add_service(ts, f"{name}_GetResult", "unique_identifier_msgs/UUID goal_id\n", f"int8 status\n{name}_Result result\n")
    add(ts, f"unique_identifier_msgs/UUID goal_id\n{name}_Feedback feedback\n", f"{name}_FeedbackMessage")
