//! Live mode (placeholder while the scenarios are brought up).
use anyhow::Result;
use kernel::config::ArmConfig;
use protocol::feedback::FeedbackMode;

use crate::plant::PlantOptions;

/// Live-mode options.
#[derive(Clone, Debug)]
pub struct LiveOptions {
    /// Also listen on this TCP address.
    pub tcp: Option<String>,
    /// Simulated ms per wall ms.
    pub speed: f64,
    /// Stop after this many wall seconds.
    pub run_for: Option<f64>,
    /// Feedback lines sent.
    pub feedback: FeedbackMode,
    /// Plant.
    pub plant: PlantOptions,
}

impl LiveOptions {
    /// Defaults.
    pub fn new(cfg: &ArmConfig) -> Self {
        LiveOptions {
            tcp: None,
            speed: 1.0,
            run_for: None,
            feedback: FeedbackMode::Both,
            plant: PlantOptions::new(cfg),
        }
    }
}

/// Runs live mode.
pub fn run_live(_cfg: &ArmConfig, _o: &LiveOptions) -> Result<()> {
    anyhow::bail!("not yet")
}
