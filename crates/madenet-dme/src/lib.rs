//! The DME-DRL baseline (He et al., decentralized multi-robot exploration with multi-agent deep
//! RL; MADDPG with decentralized actors and centralized critics), as the MADE-Net paper compares
//! against it. So far: **the action space** — a robot chooses one of 8 angular sectors around
//! it; the goal is the nearest (by path through its known free cells) frontier cell in that
//! sector; sectors without a reachable frontier cell are masked. **The networks** ([`nets`]: actor and centralized
//! critic with shape tests) are in place; the trainer and the policy follow (see `docs/design/dme-drl-brief.md` for what the original code does).

pub mod nets;
pub mod sectors;

pub use sectors::{sector_goals, sector_of, SectorGoals, SECTORS};
