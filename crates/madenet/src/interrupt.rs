//! Ctrl-C (SIGINT) or SIGTERM during a `run` that records, streams or is paced: the run stops
//! after the timestep it is in and finishes what it writes — the bag then holds the run up to
//! there, a valid bag, instead of a hidden partial folder — and `madenet` exits with 130
//! (128 + SIGINT; 143 for SIGTERM). A second signal ends the process at once, with the same
//! codes.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Whether the user asked the run to stop ([module docs](self)): one flag per signal watched.
pub struct Stop(Vec<(i32, Arc<AtomicBool>)>);

impl Stop {
    /// Watches SIGINT and SIGTERM when `wanted`; otherwise they end the process as usual.
    pub fn watch(wanted: bool) -> anyhow::Result<Self> {
        if !wanted {
            return Ok(Stop(Vec::new()));
        }
        let flags = [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM]
            .map(|s| (s, Arc::new(AtomicBool::new(false))));
        for (signal, _) in &flags {
            for (_, flag) in &flags {
                // A second signal (either flag already set) exits at once, with 128 + signal.
                signal_hook::flag::register_conditional_shutdown(
                    *signal,
                    128 + *signal,
                    Arc::clone(flag),
                )?;
            }
        }
        for (signal, flag) in &flags {
            signal_hook::flag::register(*signal, Arc::clone(flag))?;
        }
        Ok(Stop(flags.into()))
    }

    /// The signal that came, if one did.
    pub fn requested(&self) -> Option<i32> {
        self.0
            .iter()
            .find(|(_, f)| f.load(Ordering::Relaxed))
            .map(|(s, _)| *s)
    }
}

/// A run ended by a signal after its outputs were finished; `madenet` exits with 128 + the
/// signal (130 for Ctrl-C, 143 for SIGTERM).
#[derive(Debug, thiserror::Error)]
#[error("interrupted at {at}; everything asked for (bag, pictures) is finished and ends there")]
pub struct Interrupted {
    /// Where the run stopped: `timestep 37`, `12.4 s`.
    pub at: String,
    /// The signal.
    pub signal: i32,
}
