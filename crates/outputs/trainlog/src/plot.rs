//! Fig. 2 of the paper from a run directory's CSV logs.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use madenet_plots::{ewma, styled_line_panels, LinePanel, LineSeries, LineStyle};

use crate::log::{read_episodes, read_validation, Env, EpisodeRow, LogRow, ValidationRow};
use crate::TrainLogError;

/// The smoothing factor of the curves of Fig. 2 ("EWMA of 0.9").
pub const EWMA_ALPHA: f64 = 0.9;

/// The figure's file name in a run directory when no other is given.
pub const DEFAULT_FIGURE: &str = "fig2_training.png";

/// Palette index of each environment's curves and of the validation curve
/// (blue, vermillion, bluish green), the same whichever are present.
const fn colour(env: Env) -> usize {
    match env {
        Env::Cen => 0,
        Env::Dec => 1,
    }
}
const VALIDATION_COLOUR: usize = 2;

fn env_label(env: Env) -> &'static str {
    match env {
        Env::Cen => "centralized",
        Env::Dec => "decentralized",
    }
}

/// Draws Fig. 2 of the paper from `run_dir/episodes.csv` into `out`, a
/// PNG or an SVG by its extension; returns `out`.
///
/// Two panels side by side: the team reward (left) and the number of steps
/// (right) of every training episode against the episode index. Each
/// environment present (`cen`, `dec`) is one colour: its raw per-episode
/// values thin and faint, their EWMA with factor [`EWMA_ALPHA`] (computed
/// over that environment's episodes in order) bold, with markers. If
/// `run_dir/validation.csv` exists and has rows, a third panel shows the
/// validation rounds' mean steps against the episode they ran at.
///
/// Where an episode number occurs more than once (a run resumed from a
/// checkpoint older than its log appends episodes again), the last row
/// counts; rows are drawn in episode order.
///
/// # Errors
///
/// [`TrainLogError::NoEpisodes`] if `episodes.csv` has no rows; the errors
/// of [`read_episodes`] and [`read_validation`] (a missing `episodes.csv`
/// is [`TrainLogError::Io`] naming it; a missing `validation.csv` is no
/// error); [`TrainLogError::Plot`] if `out` does not end in `.png` or
/// `.svg` or cannot be written.
pub fn plot_training(run_dir: &Path, out: &Path) -> Result<PathBuf, TrainLogError> {
    let ep_path = run_dir.join(EpisodeRow::FILE_NAME);
    let episodes = last_per_episode(read_episodes(&ep_path)?, |r| r.episode);
    if episodes.is_empty() {
        return Err(TrainLogError::NoEpisodes { path: ep_path });
    }
    let val_path = run_dir.join(ValidationRow::FILE_NAME);
    let validation = match read_validation(&val_path) {
        Err(TrainLogError::Io { source, .. }) if source.kind() == std::io::ErrorKind::NotFound => {
            Vec::new()
        }
        r => last_per_episode(r?, |r| r.episode),
    };

    let mut reward = Vec::new();
    let mut steps = Vec::new();
    let mut styles = Vec::new();
    let mut smooth_reward = Vec::new();
    let mut smooth_steps = Vec::new();
    for env in [Env::Cen, Env::Dec] {
        let rows: Vec<&EpisodeRow> = episodes.iter().filter(|r| r.env == env).collect();
        if rows.is_empty() {
            continue;
        }
        let raw_name = format!("{}: per episode", env_label(env));
        let ewma_name = format!("{}: EWMA {EWMA_ALPHA}", env_label(env));
        let xs: Vec<f64> = rows.iter().map(|r| r.episode as f64).collect();
        let series = |name: &str, ys: &[f64]| LineSeries {
            name: name.to_string(),
            points: xs.iter().copied().zip(ys.iter().copied()).collect(),
        };
        let r: Vec<f64> = rows.iter().map(|r| r.team_reward).collect();
        let s: Vec<f64> = rows.iter().map(|r| f64::from(r.steps)).collect();
        reward.push(series(&raw_name, &r));
        steps.push(series(&raw_name, &s));
        smooth_reward.push(series(&ewma_name, &ewma(&r, EWMA_ALPHA)));
        smooth_steps.push(series(&ewma_name, &ewma(&s, EWMA_ALPHA)));
        for (name, faint) in [(ewma_name, false), (raw_name, true)] {
            styles.push(LineStyle {
                name,
                colour: colour(env),
                faint,
            });
        }
    }
    // The smoothed curves on top of all raw values.
    reward.extend(smooth_reward);
    steps.extend(smooth_steps);
    let panel = |title: &str, y_label: &str, series| LinePanel {
        title: title.into(),
        x_label: "Episode".into(),
        y_label: y_label.into(),
        series,
    };
    let mut panels = vec![
        panel("Team reward per episode", "Team reward", reward),
        panel("Steps per episode", "Steps", steps),
    ];
    if !validation.is_empty() {
        let trials = validation[0].trials;
        let name = if validation.iter().all(|v| v.trials == trials) {
            format!(
                "validation: mean of {trials} trial{}",
                if trials == 1 { "" } else { "s" }
            )
        } else {
            "validation: mean over trials".to_string()
        };
        let points = validation
            .iter()
            .map(|v| (v.episode as f64, v.mean_steps))
            .collect();
        panels.push(panel(
            "Validation",
            "Mean steps",
            vec![LineSeries {
                name: name.clone(),
                points,
            }],
        ));
        styles.push(LineStyle {
            name,
            colour: VALIDATION_COLOUR,
            faint: false,
        });
    }
    let cols = panels.len();
    Ok(styled_line_panels(out, &panels, cols, &styles)?)
}

/// The rows sorted by episode, keeping the last row of each episode.
fn last_per_episode<R>(rows: Vec<R>, episode: impl Fn(&R) -> u64) -> Vec<R> {
    let mut by_episode = BTreeMap::new();
    for r in rows {
        by_episode.insert(episode(&r), r);
    }
    by_episode.into_values().collect()
}
