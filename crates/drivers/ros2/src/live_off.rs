//! The live view when this build has no `foxglove` feature: [`Live::start`] refuses, naming
//! the feature, so callers need no feature gate of their own.

use crate::msgs::RosMessage;

pub use crate::LiveError;

/// No live view in this build.
pub struct Live {
    url: String,
}

impl Live {
    /// Refuses: this build has no live view.
    pub fn start(addr: &str) -> Result<Self, LiveError> {
        Err(LiveError {
            addr: addr.to_string(),
            why: "this madenet was built without the `foxglove` feature".into(),
        })
    }
    /// Never reached (no live view starts).
    pub fn url(&self) -> &str {
        &self.url
    }
    /// No viewers.
    pub fn clients(&self) -> usize {
        0
    }
    /// Nothing to send to.
    pub fn write_cdr<T: RosMessage>(&mut self, _topic: &str, _cdr: &[u8], _t_ns: u64) {}
}
