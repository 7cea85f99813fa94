//! Episodes of primitive steps and their squeezing into macro steps (MacDec-DDRQN, Xiao et al.
//! ICRA 2020, as MADE-Net trains): the replay keeps whole episodes at the primitive level with
//! each robot's "macro action terminated" flag; training turns them into macro-level
//! transitions — for each robot's DEP at its own terminations, for the CEP at every step where
//! any robot's macro action ended (the joint-valid steps) — summing the rewards undiscounted
//! inside a macro action, so that γ applies once per macro step.
//!
//! Observations are not copied here: a transition names the primitive steps whose stored
//! observations it uses.

/// One primitive timestep of an episode, as recorded after the world moved.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PrimitiveStep {
    /// Per robot: a new macro action was chosen at this step (its previous one terminated, or
    /// the episode started). The observation of this step is the one it was chosen on.
    pub decided: Vec<bool>,
    /// Per robot: the macro action (goal candidate index) in force during this step.
    pub actions: Vec<usize>,
    /// Per robot: r_i of Eq. (7) for this step.
    pub robot_rewards: Vec<f32>,
    /// r of Eq. (8) for this step.
    pub team_reward: f32,
}

/// A macro-level transition: the observation of step `from`, the action chosen there, the
/// rewards summed over steps `from..to`, and the next decision's observation at step `to`
/// (`None` when the episode ended first: a terminal transition).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MacroTransition {
    /// The primitive step whose observation the action was chosen on.
    pub from: usize,
    /// The primitive step of the next decision (its observation bootstraps); `None`: terminal.
    pub to: Option<usize>,
    /// The action: a robot's candidate index (DEP) or the joint actions in force (CEP).
    pub actions: Vec<usize>,
    /// Per robot in the CEP: whether its macro action was chosen at `from` (the others were
    /// still running and stay fixed in the conditional argmax of Eq. 5). One entry for a DEP.
    pub decided: Vec<bool>,
    /// The undiscounted sum of the rewards of steps `from..to` (or to the episode's end).
    pub reward: f32,
}

/// Why an episode cannot be squeezed.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ReplayError {
    /// A step's per-robot list does not have one entry per robot (the team size being the
    /// length of the first step's `decided`).
    #[error("step {step}: {what} has {got} entries for {robots} robots")]
    Ragged {
        /// Index of the offending step.
        step: usize,
        /// The list: `decided`, `actions` or `robot_rewards`.
        what: &'static str,
        /// Its length.
        got: usize,
        /// The team size.
        robots: usize,
    },
    /// A robot did not decide at the episode's first step, so its first macro action has no
    /// observation.
    #[error("the first step must be a decision of every robot (robot {robot} did not decide)")]
    NoInitialDecision {
        /// The robot that did not decide.
        robot: usize,
    },
    /// A robot index beyond the team was asked for.
    #[error("robot {robot} is out of range for a team of {robots}")]
    NoSuchRobot {
        /// The robot asked for.
        robot: usize,
        /// The team size.
        robots: usize,
    },
}

fn check(steps: &[PrimitiveStep]) -> Result<usize, ReplayError> {
    let n = steps.first().map_or(0, |s| s.decided.len());
    for (i, s) in steps.iter().enumerate() {
        for (what, got) in [
            ("decided", s.decided.len()),
            ("actions", s.actions.len()),
            ("robot_rewards", s.robot_rewards.len()),
        ] {
            if got != n {
                return Err(ReplayError::Ragged {
                    step: i,
                    what,
                    got,
                    robots: n,
                });
            }
        }
    }
    if let Some(first) = steps.first() {
        if let Some(robot) = first.decided.iter().position(|d| !d) {
            return Err(ReplayError::NoInitialDecision { robot });
        }
    }
    Ok(n)
}

/// Splits `0..len` at the steps where `boundary` holds (the first step always is one) into
/// macro transitions, summing `reward(step)` inside each.
fn squeeze(
    len: usize,
    boundary: impl Fn(usize) -> bool,
    reward: impl Fn(usize) -> f32,
    make: impl Fn(usize) -> (Vec<usize>, Vec<bool>),
) -> Vec<MacroTransition> {
    let starts: Vec<usize> = (0..len).filter(|&t| t == 0 || boundary(t)).collect();
    starts
        .iter()
        .enumerate()
        .map(|(k, &from)| {
            let to = starts.get(k + 1).copied();
            let end = to.unwrap_or(len);
            let (actions, decided) = make(from);
            MacroTransition {
                from,
                to,
                actions,
                decided,
                reward: (from..end).map(&reward).sum(),
            }
        })
        .collect()
}

/// The DEP transitions of `robot`: one per macro action it chose, rewards r_i summed.
pub fn squeeze_robot(
    steps: &[PrimitiveStep],
    robot: usize,
) -> Result<Vec<MacroTransition>, ReplayError> {
    let n = check(steps)?;
    if robot >= n && !steps.is_empty() {
        return Err(ReplayError::NoSuchRobot { robot, robots: n });
    }
    Ok(squeeze(
        steps.len(),
        |t| steps[t].decided[robot],
        |t| steps[t].robot_rewards[robot],
        |t| (vec![steps[t].actions[robot]], vec![true]),
    ))
}

/// The CEP transitions: one per joint-valid step (any robot decided), team rewards summed.
pub fn squeeze_team(steps: &[PrimitiveStep]) -> Result<Vec<MacroTransition>, ReplayError> {
    check(steps)?;
    Ok(squeeze(
        steps.len(),
        |t| steps[t].decided.iter().any(|&d| d),
        |t| steps[t].team_reward,
        |t| (steps[t].actions.clone(), steps[t].decided.clone()),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn step(decided: [bool; 2], actions: [usize; 2], r: [f32; 2], team: f32) -> PrimitiveStep {
        PrimitiveStep {
            decided: decided.to_vec(),
            actions: actions.to_vec(),
            robot_rewards: r.to_vec(),
            team_reward: team,
        }
    }

    /// Robot 0 decides at 0 and 3, robot 1 at 0 and 2; five steps.
    fn episode() -> Vec<PrimitiveStep> {
        vec![
            step([true, true], [1, 2], [1.0, 10.0], 100.0),
            step([false, false], [1, 2], [2.0, 20.0], 200.0),
            step([false, true], [1, 0], [3.0, 30.0], 300.0),
            step([true, false], [3, 0], [4.0, 40.0], 400.0),
            step([false, false], [3, 0], [5.0, 50.0], 500.0),
        ]
    }

    #[test]
    fn robot_macro_steps_sum_rewards_within_macro_actions() {
        let e = episode();
        let r0 = squeeze_robot(&e, 0).unwrap();
        assert_eq!(r0.len(), 2);
        assert_eq!(
            (r0[0].from, r0[0].to, r0[0].actions.clone(), r0[0].reward),
            (0, Some(3), vec![1], 6.0)
        );
        assert_eq!(
            (r0[1].from, r0[1].to, r0[1].actions.clone(), r0[1].reward),
            (3, None, vec![3], 9.0)
        );
        let r1 = squeeze_robot(&e, 1).unwrap();
        assert_eq!((r1[0].from, r1[0].to, r1[0].reward), (0, Some(2), 30.0));
        assert_eq!(
            (r1[1].from, r1[1].to, r1[1].actions.clone(), r1[1].reward),
            (2, None, vec![0], 120.0)
        );
    }

    #[test]
    fn team_macro_steps_at_joint_valid_steps() {
        let t = squeeze_team(&episode()).unwrap();
        let spans: Vec<(usize, Option<usize>, f32)> =
            t.iter().map(|m| (m.from, m.to, m.reward)).collect();
        assert_eq!(
            spans,
            vec![(0, Some(2), 300.0), (2, Some(3), 300.0), (3, None, 900.0)]
        );
        // At step 2 only robot 1 decided: robot 0's action stays fixed (conditional argmax).
        assert_eq!(t[1].decided, vec![false, true]);
        assert_eq!(t[1].actions, vec![1, 0]);
        // Rewards are conserved: every primitive reward lands in exactly one macro step.
        let total: f32 = episode().iter().map(|s| s.team_reward).sum();
        assert_eq!(t.iter().map(|m| m.reward).sum::<f32>(), total);
    }

    #[test]
    fn bad_episodes() {
        let mut e = episode();
        e[0].decided[1] = false;
        assert_eq!(
            squeeze_team(&e),
            Err(ReplayError::NoInitialDecision { robot: 1 })
        );
        let mut e = episode();
        e[3].actions.pop();
        assert!(matches!(
            squeeze_robot(&e, 0),
            Err(ReplayError::Ragged {
                step: 3,
                what: "actions",
                ..
            })
        ));
        assert_eq!(
            squeeze_robot(&episode(), 2),
            Err(ReplayError::NoSuchRobot {
                robot: 2,
                robots: 2
            })
        );
        assert_eq!(squeeze_team(&[]), Ok(vec![]));
    }
}
