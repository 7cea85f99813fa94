//! ROS 2 actions in the rmw_zenoh wire format (Jazzy), built from [`crate::services`] and
//! topics ([`crate::rmw`]) as rcl builds them:
//!
//! | part | name | type |
//! | --- | --- | --- |
//! | service | `<action>/_action/send_goal` | `<Action>_SendGoal` |
//! | service | `<action>/_action/get_result` | `<Action>_GetResult` |
//! | service | `<action>/_action/cancel_goal` | `action_msgs/srv/CancelGoal` |
//! | topic | `<action>/_action/feedback` | `<Action>_FeedbackMessage` |
//! | topic | `<action>/_action/status` (reliable, transient local, depth 1) | `action_msgs/msg/GoalStatusArray` |
//!
//! Goals are named by 16-byte UUIDs; their states follow `action_msgs/msg/GoalStatus`
//! ([`status`]). An [`ActionServer`] answers `get_result` when the goal ends, however long
//! that takes: the request is held, not answered with a timeout, and the
//! [`ActionClient`]'s query never times out on its own.

use crate::msgs::{self, PoseStamped, RosMessage, Time};
use crate::rmw::{Durability, Node, Publisher, QosProfile, Reliability, Subscription};
use crate::services::{PendingCall, RosService, ServiceClient, ServiceRequest, ServiceServer};
use crate::Ros2Error;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::marker::PhantomData;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// `action_msgs/msg/GoalStatus` states.
pub mod status {
    /// Not known (e.g. `get_result` for a goal the server never had).
    pub const UNKNOWN: i8 = 0;
    /// Accepted, not yet executing.
    pub const ACCEPTED: i8 = 1;
    /// Executing.
    pub const EXECUTING: i8 = 2;
    /// A cancel was accepted; the server is stopping it.
    pub const CANCELING: i8 = 3;
    /// Ended: reached.
    pub const SUCCEEDED: i8 = 4;
    /// Ended: canceled.
    pub const CANCELED: i8 = 5;
    /// Ended: the server gave up.
    pub const ABORTED: i8 = 6;

    /// Whether `s` is a final state.
    pub fn is_terminal(s: i8) -> bool {
        matches!(s, SUCCEEDED | CANCELED | ABORTED)
    }
}

/// `action_msgs/srv/CancelGoal` return codes.
pub mod cancel_code {
    /// At least one goal is being canceled.
    pub const NONE: i8 = 0;
    /// The server refused.
    pub const REJECTED: i8 = 1;
    /// No goal has that id.
    pub const UNKNOWN_GOAL_ID: i8 = 2;
    /// The goal already ended.
    pub const GOAL_TERMINATED: i8 = 3;
}

/// How long an ended goal's result is kept for `get_result` (rcl's default result timeout,
/// 15 minutes).
pub const RESULT_KEPT: Duration = Duration::from_secs(900);

/// `unique_identifier_msgs/msg/UUID`.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
pub struct Uuid {
    /// The 16 bytes.
    pub uuid: [u8; 16],
}

/// `action_msgs/msg/GoalInfo`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct GoalInfo {
    /// The goal.
    pub goal_id: Uuid,
    /// When it was accepted.
    pub stamp: Time,
}

/// `action_msgs/msg/GoalStatus`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct GoalStatus {
    /// Which goal, accepted when.
    pub goal_info: GoalInfo,
    /// Its state ([`status`]).
    pub status: i8,
}

/// `action_msgs/msg/GoalStatusArray`: every goal the server knows, with its state.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct GoalStatusArray {
    /// The goals.
    pub status_list: Vec<GoalStatus>,
}

impl RosMessage for GoalStatusArray {
    const TYPE_NAME: &'static str = "action_msgs/msg/GoalStatusArray";
    const DEFINITION: &'static str = crate::msgdefs::GOAL_STATUS_ARRAY;
}

/// `action_msgs/srv/CancelGoal`.
pub struct CancelGoal;

/// `action_msgs/srv/CancelGoal_Request`: a zero id cancels every goal accepted at or before
/// `stamp` (a zero stamp: every goal); an id cancels that goal (and, with a stamp, those
/// before it).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct CancelGoalRequest {
    /// Which goals.
    pub goal_info: GoalInfo,
}

/// `action_msgs/srv/CancelGoal_Response`.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct CancelGoalResponse {
    /// [`cancel_code`].
    pub return_code: i8,
    /// The goals now canceling.
    pub goals_canceling: Vec<GoalInfo>,
}

impl RosService for CancelGoal {
    const TYPE_NAME: &'static str = "action_msgs/srv/CancelGoal";
    type Request = CancelGoalRequest;
    type Response = CancelGoalResponse;
}

/// A ROS 2 action type. Implement it with [`action_names!`](crate::action_names) for the
/// names.
pub trait RosAction: 'static {
    /// `pkg/action/Name`.
    const TYPE_NAME: &'static str;
    /// `pkg/action/Name_SendGoal`.
    const SEND_GOAL: &'static str;
    /// `pkg/action/Name_GetResult`.
    const GET_RESULT: &'static str;
    /// `pkg/action/Name_FeedbackMessage`.
    const FEEDBACK_MESSAGE: &'static str;
    /// `Name_Goal`.
    type Goal: Serialize + DeserializeOwned + Clone;
    /// `Name_Result` (its default is what an unknown goal's `get_result` carries).
    type Result: Serialize + DeserializeOwned + Clone + Default;
    /// `Name_Feedback`.
    type Feedback: Serialize + DeserializeOwned + Clone;
}

/// The four type names of [`RosAction`] from the action's name.
#[macro_export]
macro_rules! action_names {
    ($name:literal) => {
        const TYPE_NAME: &'static str = $name;
        const SEND_GOAL: &'static str = concat!($name, "_SendGoal");
        const GET_RESULT: &'static str = concat!($name, "_GetResult");
        const FEEDBACK_MESSAGE: &'static str = concat!($name, "_FeedbackMessage");
    };
}

/// `<Action>_SendGoal_Request`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SendGoalRequest<G> {
    /// The new goal's id, chosen by the client.
    pub goal_id: Uuid,
    /// The goal.
    pub goal: G,
}

/// `<Action>_SendGoal_Response`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct SendGoalResponse {
    /// Whether the server took the goal.
    pub accepted: bool,
    /// When.
    pub stamp: Time,
}

/// `<Action>_GetResult_Request`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct GetResultRequest {
    /// Which goal.
    pub goal_id: Uuid,
}

/// `<Action>_GetResult_Response`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GetResultResponse<R> {
    /// The goal's final state ([`status`]).
    pub status: i8,
    /// Its result.
    pub result: R,
}

/// `<Action>_FeedbackMessage`: feedback on one goal.
#[derive(Serialize, Deserialize)]
#[serde(bound(serialize = "", deserialize = ""))]
pub struct FeedbackMessage<A: RosAction> {
    /// Which goal.
    pub goal_id: Uuid,
    /// The feedback.
    pub feedback: A::Feedback,
}

impl<A: RosAction> Clone for FeedbackMessage<A> {
    fn clone(&self) -> Self {
        FeedbackMessage {
            goal_id: self.goal_id,
            feedback: self.feedback.clone(),
        }
    }
}

impl<A: RosAction> RosMessage for FeedbackMessage<A> {
    const TYPE_NAME: &'static str = A::FEEDBACK_MESSAGE;
    /// Not written to bags: madenet records no action traffic.
    const DEFINITION: &'static str = "";
}

/// The `send_goal` service of action `A`.
pub struct SendGoal<A>(PhantomData<A>);

impl<A: RosAction> RosService for SendGoal<A> {
    const TYPE_NAME: &'static str = A::SEND_GOAL;
    type Request = SendGoalRequest<A::Goal>;
    type Response = SendGoalResponse;
}

/// The `get_result` service of action `A`.
pub struct GetResult<A>(PhantomData<A>);

impl<A: RosAction> RosService for GetResult<A> {
    const TYPE_NAME: &'static str = A::GET_RESULT;
    type Request = GetResultRequest;
    type Response = GetResultResponse<A::Result>;
}

/// The QoS of an action's status topic (rcl: reliable, transient local, keep last 1).
pub fn status_qos() -> QosProfile {
    QosProfile {
        reliability: Reliability::Reliable,
        durability: Durability::TransientLocal,
        depth: 1,
    }
}

fn now() -> Time {
    crate::stamp(SystemTime::now())
}

fn part(action: &str, what: &str) -> String {
    format!("{action}/_action/{what}")
}

/// A goal sent to an [`ActionServer`], not yet answered: take it with
/// [`ActionServer::accept`] or refuse it with [`ActionServer::reject`].
pub struct GoalRequest<A: RosAction> {
    request: ServiceRequest<SendGoal<A>>,
}

impl<A: RosAction> GoalRequest<A> {
    /// The goal's id.
    pub fn id(&self) -> Uuid {
        self.request.request.goal_id
    }

    /// The goal.
    pub fn goal(&self) -> &A::Goal {
        &self.request.request.goal
    }
}

/// What an [`ActionServer`] was asked.
pub enum ActionEvent<A: RosAction> {
    /// A new goal: accept or reject it.
    Goal(GoalRequest<A>),
    /// A client asked to cancel this goal; its state is now `CANCELING`: stop it and
    /// [`ActionServer::end`] it (with `CANCELED`).
    Cancel(Uuid),
}

struct GoalEntry<R> {
    info: GoalInfo,
    status: i8,
    result: Option<R>,
    ended: Option<Instant>,
}

/// An action server of `A`: [`ActionServer::poll`] for goals and cancels, then accept,
/// send feedback and end each goal.
pub struct ActionServer<A: RosAction> {
    name: String,
    send_goal: ServiceServer<SendGoal<A>>,
    get_result: ServiceServer<GetResult<A>>,
    cancel: ServiceServer<CancelGoal>,
    feedback: Publisher<FeedbackMessage<A>>,
    status: Publisher<GoalStatusArray>,
    goals: BTreeMap<Uuid, GoalEntry<A::Result>>,
    /// `get_result` requests held until their goal ends.
    waiting: Vec<ServiceRequest<GetResult<A>>>,
    /// Cancels accepted but not yet handed to the caller of `poll`.
    canceled: Vec<Uuid>,
}

impl<A: RosAction> ActionServer<A> {
    /// A server of `A` on action `name` (relative names resolve in the node's namespace).
    pub fn new(node: &Node, name: &str) -> Result<Self, Ros2Error> {
        let name = node.resolve(name);
        let server = ActionServer {
            send_goal: ServiceServer::new(node, &part(&name, "send_goal"))?,
            get_result: ServiceServer::new(node, &part(&name, "get_result"))?,
            cancel: ServiceServer::new(node, &part(&name, "cancel_goal"))?,
            feedback: node.create_pub(&part(&name, "feedback"), QosProfile::default())?,
            status: node.create_pub(&part(&name, "status"), status_qos())?,
            name,
            goals: BTreeMap::new(),
            waiting: Vec::new(),
            canceled: Vec::new(),
        };
        server.publish_status()?;
        Ok(server)
    }

    /// The action's fully qualified name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The next goal or cancel, waiting up to `timeout`. Meanwhile it answers `get_result`
    /// for ended goals (and holds it for running ones) and forgets results older than
    /// [`RESULT_KEPT`].
    pub fn poll(&mut self, timeout: Duration) -> Result<Option<ActionEvent<A>>, Ros2Error> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(id) = self.canceled.pop() {
                return Ok(Some(ActionEvent::Cancel(id)));
            }
            while let Some(req) = self.get_result.recv_timeout(Duration::ZERO)? {
                self.answer_or_hold(req)?;
            }
            while let Some(req) = self.cancel.recv_timeout(Duration::ZERO)? {
                self.cancel_goals(req)?;
            }
            if !self.canceled.is_empty() {
                continue;
            }
            self.forget_old();
            let left = deadline.saturating_duration_since(Instant::now());
            if let Some(request) = self
                .send_goal
                .recv_timeout(left.min(Duration::from_millis(5)))?
            {
                return Ok(Some(ActionEvent::Goal(GoalRequest { request })));
            }
            if Instant::now() >= deadline {
                return Ok(None);
            }
        }
    }

    /// Takes `goal`: it is `EXECUTING` from now on.
    pub fn accept(&mut self, goal: GoalRequest<A>) -> Result<Uuid, Ros2Error> {
        let id = goal.id();
        let stamp = now();
        if self.goals.contains_key(&id) {
            tracing::warn!("{}: refused a goal whose id is taken", self.name);
            return self.reject(goal).map(|()| id);
        }
        goal.request.reply(&SendGoalResponse {
            accepted: true,
            stamp,
        })?;
        self.goals.insert(
            id,
            GoalEntry {
                info: GoalInfo { goal_id: id, stamp },
                status: status::EXECUTING,
                result: None,
                ended: None,
            },
        );
        self.publish_status()?;
        Ok(id)
    }

    /// Refuses `goal`.
    pub fn reject(&mut self, goal: GoalRequest<A>) -> Result<(), Ros2Error> {
        goal.request.reply(&SendGoalResponse {
            accepted: false,
            stamp: now(),
        })
    }

    /// Sends `feedback` on goal `id`.
    pub fn publish_feedback(&self, id: Uuid, feedback: A::Feedback) -> Result<(), Ros2Error> {
        self.feedback.publish(&FeedbackMessage {
            goal_id: id,
            feedback,
        })
    }

    /// Goal `id`'s state, if the server knows it.
    pub fn status(&self, id: Uuid) -> Option<i8> {
        self.goals.get(&id).map(|g| g.status)
    }

    /// The goals not yet ended.
    pub fn active(&self) -> Vec<Uuid> {
        self.goals
            .iter()
            .filter(|(_, g)| !status::is_terminal(g.status))
            .map(|(id, _)| *id)
            .collect()
    }

    /// Ends goal `id` with `final_status` (`SUCCEEDED`, `CANCELED` or `ABORTED`) and
    /// `result`, and answers every `get_result` waiting for it. Ending an unknown or ended
    /// goal does nothing and returns false.
    pub fn end(
        &mut self,
        id: Uuid,
        final_status: i8,
        result: A::Result,
    ) -> Result<bool, Ros2Error> {
        debug_assert!(status::is_terminal(final_status));
        let Some(g) = self.goals.get_mut(&id) else {
            return Ok(false);
        };
        if status::is_terminal(g.status) {
            return Ok(false);
        }
        g.status = final_status;
        g.result = Some(result);
        g.ended = Some(Instant::now());
        let (ready, held): (Vec<_>, Vec<_>) = std::mem::take(&mut self.waiting)
            .into_iter()
            .partition(|r| r.request.goal_id == id);
        self.waiting = held;
        for r in ready {
            self.answer_or_hold(r)?;
        }
        self.publish_status()?;
        Ok(true)
    }

    fn answer_or_hold(&mut self, req: ServiceRequest<GetResult<A>>) -> Result<(), Ros2Error> {
        match self.goals.get(&req.request.goal_id) {
            None => req.reply(&GetResultResponse {
                status: status::UNKNOWN,
                result: A::Result::default(),
            }),
            Some(GoalEntry {
                status,
                result: Some(result),
                ..
            }) => req.reply(&GetResultResponse {
                status: *status,
                result: result.clone(),
            }),
            Some(_) => {
                self.waiting.push(req);
                Ok(())
            }
        }
    }

    fn cancel_goals(&mut self, req: ServiceRequest<CancelGoal>) -> Result<(), Ros2Error> {
        let info = req.request.goal_info;
        let zero_id = info.goal_id == Uuid::default();
        let zero_stamp = info.stamp == Time::default();
        let before =
            |s: Time| !zero_stamp && (s.sec, s.nanosec) <= (info.stamp.sec, info.stamp.nanosec);
        let mut canceling = Vec::new();
        let mut any_known = false;
        for (id, g) in self.goals.iter_mut() {
            let picked = (zero_id && zero_stamp) || *id == info.goal_id || before(g.info.stamp);
            if !picked {
                continue;
            }
            any_known = true;
            if matches!(g.status, status::ACCEPTED | status::EXECUTING) {
                g.status = status::CANCELING;
                canceling.push(g.info);
                self.canceled.push(*id);
            }
        }
        let return_code = if !canceling.is_empty() {
            cancel_code::NONE
        } else if !zero_id && !any_known {
            cancel_code::UNKNOWN_GOAL_ID
        } else if any_known {
            cancel_code::GOAL_TERMINATED
        } else {
            cancel_code::REJECTED
        };
        req.reply(&CancelGoalResponse {
            return_code,
            goals_canceling: canceling.clone(),
        })?;
        if !canceling.is_empty() {
            self.publish_status()?;
        }
        Ok(())
    }

    fn forget_old(&mut self) {
        let before = self.goals.len();
        self.goals
            .retain(|_, g| g.ended.is_none_or(|t| t.elapsed() < RESULT_KEPT));
        if self.goals.len() != before {
            if let Err(e) = self.publish_status() {
                tracing::warn!("{}: status: {e}", self.name);
            }
        }
    }

    fn publish_status(&self) -> Result<(), Ros2Error> {
        self.status.publish(&GoalStatusArray {
            status_list: self
                .goals
                .values()
                .map(|g| GoalStatus {
                    goal_info: g.info,
                    status: g.status,
                })
                .collect(),
        })
    }

    /// Malformed requests refused so far on the action's three services.
    pub fn refused(&self) -> usize {
        self.send_goal.refused() + self.get_result.refused() + self.cancel.refused()
    }
}

/// An action client of `A`.
pub struct ActionClient<A: RosAction> {
    name: String,
    send_goal: ServiceClient<SendGoal<A>>,
    get_result: ServiceClient<GetResult<A>>,
    cancel: ServiceClient<CancelGoal>,
    feedback: Subscription<FeedbackMessage<A>>,
    status: Subscription<GoalStatusArray>,
    counter: AtomicU64,
}

/// A goal the server accepted: its result comes on [`SentGoal::result`].
pub struct SentGoal<A: RosAction> {
    /// The goal's id.
    pub id: Uuid,
    /// When the server accepted it.
    pub stamp: Time,
    result: PendingCall<GetResult<A>>,
}

impl<A: RosAction> SentGoal<A> {
    /// The goal's final state and result, waiting up to `timeout`; `Ok(None)` while it runs
    /// (ask again: the request stays pending however long the goal takes).
    pub fn result(&self, timeout: Duration) -> Result<Option<(i8, A::Result)>, Ros2Error> {
        Ok(self
            .result
            .recv_timeout(timeout)?
            .map(|r| (r.status, r.result)))
    }
}

impl<A: RosAction> ActionClient<A> {
    /// A client of action `name` (relative names resolve in the node's namespace).
    pub fn new(node: &Node, name: &str) -> Result<Self, Ros2Error> {
        let name = node.resolve(name);
        Ok(ActionClient {
            send_goal: ServiceClient::new(node, &part(&name, "send_goal"))?,
            get_result: ServiceClient::new(node, &part(&name, "get_result"))?,
            cancel: ServiceClient::new(node, &part(&name, "cancel_goal"))?,
            feedback: node.create_sub(&part(&name, "feedback"), QosProfile::default())?,
            status: node.create_sub(&part(&name, "status"), status_qos())?,
            name,
            counter: AtomicU64::new(0),
        })
    }

    /// The action's fully qualified name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Whether the action's server is in the ROS graph, waiting up to `timeout`.
    pub fn wait_for_server(&self, timeout: Duration) -> Result<bool, Ros2Error> {
        let deadline = Instant::now() + timeout;
        for c in [
            self.send_goal.wait_for_server(timeout)?,
            self.get_result
                .wait_for_server(deadline.saturating_duration_since(Instant::now()))?,
            self.cancel
                .wait_for_server(deadline.saturating_duration_since(Instant::now()))?,
        ] {
            if !c {
                return Ok(false);
            }
        }
        Ok(true)
    }

    /// A fresh goal id: XXH3-128 of the client's GID, a counter and the time (unique per
    /// client and call; not a result, so not drawn from a seeded stream).
    fn new_id(&self) -> Uuid {
        let mut bytes = self.send_goal.gid().to_vec();
        bytes.extend(self.counter.fetch_add(1, Ordering::Relaxed).to_le_bytes());
        let t = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .unwrap_or_default()
            .as_nanos();
        bytes.extend(t.to_le_bytes());
        Uuid {
            uuid: xxhash_rust::xxh3::xxh3_128(&bytes).to_le_bytes(),
        }
    }

    /// Sends `goal` and waits up to `timeout` for the server's answer: `Ok(None)` if it
    /// rejected the goal. An accepted goal's result is asked for at once, so it is never
    /// missed.
    pub fn send_goal(
        &self,
        goal: A::Goal,
        timeout: Duration,
    ) -> Result<Option<SentGoal<A>>, Ros2Error> {
        let id = self.new_id();
        let answer = self
            .send_goal
            .call(&SendGoalRequest { goal_id: id, goal }, timeout)?;
        if !answer.accepted {
            return Ok(None);
        }
        let result = self.get_result.send(&GetResultRequest { goal_id: id })?;
        Ok(Some(SentGoal {
            id,
            stamp: answer.stamp,
            result,
        }))
    }

    /// Asks to cancel goal `id` (`Uuid::default()`: every goal), waiting up to `timeout`.
    pub fn cancel(&self, id: Uuid, timeout: Duration) -> Result<CancelGoalResponse, Ros2Error> {
        self.cancel.call(
            &CancelGoalRequest {
                goal_info: GoalInfo {
                    goal_id: id,
                    stamp: Time::default(),
                },
            },
            timeout,
        )
    }

    /// The next feedback message (on any goal), waiting up to `timeout`.
    pub fn feedback(&self, timeout: Duration) -> Result<Option<FeedbackMessage<A>>, Ros2Error> {
        self.feedback.recv_timeout(timeout)
    }

    /// The next status array, waiting up to `timeout`.
    pub fn status(&self, timeout: Duration) -> Result<Option<GoalStatusArray>, Ros2Error> {
        self.status.recv_timeout(timeout)
    }
}

/// `nav2_msgs/action/NavigateToPose` (Jazzy): drive to a pose.
pub struct NavigateToPose;

/// `nav2_msgs/action/NavigateToPose_Goal`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NavigateToPoseGoal {
    /// Where to, in which frame.
    pub pose: PoseStamped,
    /// A behaviour tree to use instead of the default (`""`: the default).
    pub behavior_tree: String,
}

impl NavigateToPoseGoal {
    /// A goal at (`x`, `y`) in `frame`, facing `yaw` (rad), with the default behaviour tree.
    pub fn at(frame: &str, x: f64, y: f64, yaw: f64) -> Self {
        let mut pose = PoseStamped::default();
        pose.header.frame_id = frame.to_string();
        pose.pose.position.x = x;
        pose.pose.position.y = y;
        pose.pose.orientation = crate::tf::from_yaw(yaw);
        NavigateToPoseGoal {
            pose,
            behavior_tree: String::new(),
        }
    }
}

/// `nav2_msgs/action/NavigateToPose_Result`: `error_code` 0 on success, else nav2's code
/// ([`nav2_error`]).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct NavigateToPoseResult {
    /// 0, or the failing server's code.
    pub error_code: u16,
    /// What failed, for people.
    pub error_msg: String,
}

/// `nav2_msgs/action/NavigateToPose_Feedback`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NavigateToPoseFeedback {
    /// Where the robot is.
    pub current_pose: PoseStamped,
    /// Time since the goal was accepted.
    pub navigation_time: msgs::Duration,
    /// Estimated time to the goal.
    pub estimated_time_remaining: msgs::Duration,
    /// Recoveries so far.
    pub number_of_recoveries: i16,
    /// Path length left (m).
    pub distance_remaining: f32,
}

impl RosAction for NavigateToPose {
    crate::action_names!("nav2_msgs/action/NavigateToPose");
    type Goal = NavigateToPoseGoal;
    type Result = NavigateToPoseResult;
    type Feedback = NavigateToPoseFeedback;
}

/// nav2's error codes (Jazzy) that a `NavigateToPose` result carries: the action's own
/// (`NavigateToPose.action`), and those bt_navigator passes up from the behaviour tree's
/// planner (`ComputePathToPose`, 2xx) and controller (`FollowPath`, 1xx) when they fail.
pub mod nav2_error {
    /// No error.
    pub const NONE: u16 = 0;
    /// FollowPath: the progress checker saw too little progress.
    pub const FAILED_TO_MAKE_PROGRESS: u16 = 105;
    /// ComputePathToPose: the goal could not be transformed into the map frame.
    pub const PLANNER_TF_ERROR: u16 = 202;
    /// ComputePathToPose: the goal is outside the map.
    pub const GOAL_OUTSIDE_MAP: u16 = 204;
    /// ComputePathToPose: the start is in an occupied cell.
    pub const START_OCCUPIED: u16 = 205;
    /// ComputePathToPose: the goal is in an occupied cell.
    pub const GOAL_OCCUPIED: u16 = 206;
    /// ComputePathToPose: no path reaches the goal.
    pub const NO_VALID_PATH: u16 = 208;
    /// NavigateToPose: an error without a more specific code.
    pub const UNKNOWN: u16 = 9000;
    /// NavigateToPose: the behaviour tree named in the goal could not be loaded.
    pub const FAILED_TO_LOAD_BEHAVIOR_TREE: u16 = 9001;
    /// NavigateToPose: the goal could not be transformed.
    pub const TF_ERROR: u16 = 9002;
}

/// `example_interfaces/action/Fibonacci`: the action of ROS 2's tutorials, for tests and
/// interoperability checks.
pub struct Fibonacci;

/// `example_interfaces/action/Fibonacci_Goal`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct FibonacciGoal {
    /// How many numbers.
    pub order: i32,
}

/// `example_interfaces/action/Fibonacci_Result` and `_Feedback`.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct FibonacciSequence {
    /// The numbers so far.
    pub sequence: Vec<i32>,
}

impl RosAction for Fibonacci {
    crate::action_names!("example_interfaces/action/Fibonacci");
    type Goal = FibonacciGoal;
    type Result = FibonacciSequence;
    type Feedback = FibonacciSequence;
}
