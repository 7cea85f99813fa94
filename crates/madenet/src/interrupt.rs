//! Ctrl-C (SIGINT) or SIGTERM during a `run` that records, streams or is paced: the run stops
//! after the timestep it is in and finishes what it writes — the bag then holds the run up to
//! there, a valid bag, instead of a hidden partial folder — and `madenet` exits with 130
//! (128 + SIGINT). A second Ctrl-C ends the process at once.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Whether the user asked the run to stop ([module docs](self)).
pub struct Stop(Option<Arc<AtomicBool>>);

impl Stop {
    /// Watches SIGINT and SIGTERM when `wanted`; otherwise they end the process as usual.
    pub fn watch(wanted: bool) -> anyhow::Result<Self> {
        if !wanted {
            return Ok(Stop(None));
        }
        let flag = Arc::new(AtomicBool::new(false));
        for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
            // The second signal (the flag already set) exits at once, with code 1.
            signal_hook::flag::register_conditional_shutdown(signal, 1, Arc::clone(&flag))?;
            signal_hook::flag::register(signal, Arc::clone(&flag))?;
        }
        Ok(Stop(Some(flag)))
    }

    /// True once a signal came.
    pub fn requested(&self) -> bool {
        self.0.as_ref().is_some_and(|f| f.load(Ordering::Relaxed))
    }
}

/// A run ended by Ctrl-C after its outputs were finished; `madenet` exits with 130.
#[derive(Debug, thiserror::Error)]
#[error("interrupted at {at}; everything asked for (bag, pictures) is finished and ends there")]
pub struct Interrupted {
    /// Where the run stopped: `timestep 37`, `12.4 s`.
    pub at: String,
}
