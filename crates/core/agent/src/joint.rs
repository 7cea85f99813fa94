//! The one encoding of a team's joint macro action as an index, used by the learner's CEP, the
//! step-wise environments and the Python `CentralizedEnv`: a = Σ k_i·|G|^i, robot 0 the least
//! significant digit.

/// The joint index of per-robot actions `actions` (each `< goals`).
///
/// # Panics
/// If an action is out of range or the index overflows `usize`.
pub fn joint_encode(actions: &[usize], goals: usize) -> usize {
    actions.iter().rev().fold(0usize, |acc, &a| {
        assert!(
            a < goals,
            "robot action {a} out of range for {goals} candidates"
        );
        acc.checked_mul(goals)
            .and_then(|x| x.checked_add(a))
            .expect("joint index overflows usize")
    })
}

/// Robot `robot`'s part of joint index `index` (inverse of [`joint_encode`], one digit).
pub fn joint_digit(index: usize, robot: usize, goals: usize) -> usize {
    let mut rest = index;
    for _ in 0..robot {
        rest /= goals;
    }
    rest % goals
}

/// The per-robot actions of joint index `index` for `team` robots (inverse of
/// [`joint_encode`]).
pub fn joint_decode(index: usize, team: usize, goals: usize) -> Vec<usize> {
    let mut rest = index;
    (0..team)
        .map(|_| {
            let k = rest % goals;
            rest /= goals;
            k
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn robot_zero_is_the_least_significant_digit() {
        assert_eq!(joint_encode(&[1, 0, 0], 4), 1);
        assert_eq!(joint_encode(&[0, 1, 0], 4), 4);
        assert_eq!(joint_encode(&[3, 2, 1], 4), 3 + 2 * 4 + 16);
        for a in 0..64 {
            let parts = joint_decode(a, 3, 4);
            assert_eq!(joint_encode(&parts, 4), a);
            for (r, &k) in parts.iter().enumerate() {
                assert_eq!(joint_digit(a, r, 4), k);
            }
        }
    }
}
