//! The groove controllers a runtime can run.

use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::error::RuntimeError;

/// A groove controller (the PZT-actuated spindle, `000_…txt` ch. 6–7), by its CLI name.
///
/// ```
/// use millcomp_runtime::ControllerKind;
/// let k: ControllerKind = "pid-ff".parse().unwrap();
/// assert_eq!(k, ControllerKind::PidFeedforward);
/// assert_eq!(k.name(), "pid-ff");
/// let err = "lqr".parse::<ControllerKind>().unwrap_err().to_string();
/// assert!(err.contains("lqr") && err.contains("mpc-nopreview"), "{err}");
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
pub enum ControllerKind {
    /// No compensation: the stack held where the tool was touched off.
    #[serde(rename = "none")]
    None,
    /// Open-loop compensation: the planned deflection driven through the spindle's static gain.
    #[serde(rename = "open-loop")]
    OpenLoop,
    /// The published PID (P 400, I 800 000, D 0) with the thesis' signal chain.
    #[serde(rename = "pid")]
    Pid,
    /// The published PID with back-calculation anti-windup.
    #[serde(rename = "pid-aw")]
    PidAntiWindup,
    /// The root-locus design PID (P 844, I 130 820, D 0.4).
    #[serde(rename = "pid-design")]
    PidDesign,
    /// The strongest feedback PI on the MPC's signal chain (gains from a fixed rule on the spindle
    /// model).
    #[serde(rename = "pid-tuned")]
    PidTuned,
    /// `pid-tuned` plus the planned deflection fed forward.
    #[serde(rename = "pid-ff")]
    PidFeedforward,
    /// `pid-ff` reading what the MPC's read features read.
    #[serde(rename = "pid-ff-read")]
    PidFeedforwardRead,
    /// The model-predictive controller with preview of the program, solved with Clarabel every cycle.
    #[default]
    #[serde(rename = "mpc")]
    Mpc,
    /// The MPC without preview (the ablation).
    #[serde(rename = "mpc-nopreview")]
    MpcNoPreview,
}

impl ControllerKind {
    /// Every kind, in CLI order.
    pub const ALL: [ControllerKind; 10] = [
        ControllerKind::None,
        ControllerKind::OpenLoop,
        ControllerKind::Pid,
        ControllerKind::PidAntiWindup,
        ControllerKind::PidDesign,
        ControllerKind::PidTuned,
        ControllerKind::PidFeedforward,
        ControllerKind::PidFeedforwardRead,
        ControllerKind::Mpc,
        ControllerKind::MpcNoPreview,
    ];

    /// The CLI name.
    pub fn name(self) -> &'static str {
        match self {
            ControllerKind::None => "none",
            ControllerKind::OpenLoop => "open-loop",
            ControllerKind::Pid => "pid",
            ControllerKind::PidAntiWindup => "pid-aw",
            ControllerKind::PidDesign => "pid-design",
            ControllerKind::PidTuned => "pid-tuned",
            ControllerKind::PidFeedforward => "pid-ff",
            ControllerKind::PidFeedforwardRead => "pid-ff-read",
            ControllerKind::Mpc => "mpc",
            ControllerKind::MpcNoPreview => "mpc-nopreview",
        }
    }

    /// Built from the bundle's models and driven through the inverse of its hysteresis model when
    /// `compensate_hysteresis` is on: every controller but `none` and the published PIDs.
    pub fn hysteresis_compensated(self) -> bool {
        !matches!(
            self,
            ControllerKind::None
                | ControllerKind::Pid
                | ControllerKind::PidAntiWindup
                | ControllerKind::PidDesign
        )
    }

    /// Solves a QP every MPC period (`mpc`, `mpc-nopreview`).
    pub fn is_mpc(self) -> bool {
        matches!(self, ControllerKind::Mpc | ControllerKind::MpcNoPreview)
    }
}

impl FromStr for ControllerKind {
    type Err = RuntimeError;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| RuntimeError::UnknownController {
                name: s.to_string(),
                allowed: Self::ALL.map(Self::name).join(", "),
            })
    }
}

impl std::fmt::Display for ControllerKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}
