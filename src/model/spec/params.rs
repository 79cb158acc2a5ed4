//! The parameters of the law and its scenes, and which runs use them under a forward model
//! ("model only what a scene needs").

use serde::{Deserialize, Serialize};

use super::schema::{Aging, Level};
use crate::law::{LawKind, Scene, StateLaw};

/// The parameters of the law and its scenes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Param {
    /// Shear-rejuvenation constant α (1/m).
    #[serde(rename = "alpha")]
    Alpha,
    /// Aging amplitude a (N), or a/F_d when `aging = "ratio"`; under rate-and-state the
    /// direct-effect amplitude a (N).
    #[serde(rename = "a")]
    A,
    /// Rate-and-state evolution-effect amplitude b (N).
    #[serde(rename = "b")]
    B,
    /// Rate-and-state critical slip distance D_c (m).
    #[serde(rename = "D_c")]
    Dc,
    /// Steady-state friction F_d (N); under rate-and-state F0, the steady force at the
    /// reference velocity.
    #[serde(rename = "F_d")]
    FD,
    /// Short-time cut-off t0 (s); under rate-and-state the contact's age θ(0) at the start
    /// of a first slide.
    #[serde(rename = "t0")]
    T0,
    /// Machine stiffness k (N/m).
    #[serde(rename = "k")]
    K,
    /// Noise standard deviation σ (N).
    #[serde(rename = "sigma")]
    Sigma,
}

impl Param {
    /// All parameters, in reporting order.
    pub const ALL: [Param; 8] = [
        Self::Alpha,
        Self::A,
        Self::B,
        Self::Dc,
        Self::FD,
        Self::T0,
        Self::K,
        Self::Sigma,
    ];

    /// The name used in files and summaries.
    pub fn name(self) -> &'static str {
        match self {
            Self::Alpha => "alpha",
            Self::A => "a",
            Self::B => "b",
            Self::Dc => "D_c",
            Self::FD => "F_d",
            Self::T0 => "t0",
            Self::K => "k",
            Self::Sigma => "sigma",
        }
    }

    /// SI unit.
    pub fn unit(self) -> &'static str {
        match self {
            Self::Alpha => "1/m",
            Self::A | Self::B | Self::FD | Self::Sigma => "N",
            Self::Dc => "m",
            Self::T0 => "s",
            Self::K => "N/m",
        }
    }

    /// The default level (docs/model.md §5), used when the model file says nothing.
    pub(crate) fn default_level(self) -> Level {
        match self {
            Self::Alpha | Self::A | Self::B | Self::Dc => Level::Material,
            Self::FD | Self::K => Level::Contact,
            Self::T0 | Self::Sigma => Level::Run,
        }
    }
}

/// The forward model of a fit: the law its first and fast slides follow (`law`, with
/// `state_law` under rate-and-state) and whether the machine's spring is modelled
/// (`elastic`). It decides which parameters each run uses, and so which are sampled and
/// reported ("model only what a scene needs").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ForwardModel {
    /// The law in interface time, or rate-and-state friction.
    pub law: LawKind,
    /// `false`: the machine is rigid (k → ∞), τ = t on every slide and a repeat slide is
    /// F = F_end from its start.
    pub elastic: bool,
    /// The state law under `law = "rate-state"` (ignored under the other laws).
    pub state_law: StateLaw,
}

impl Default for ForwardModel {
    /// The aging–rejuvenation law through the machine's spring.
    fn default() -> Self {
        Self {
            law: LawKind::default(),
            elastic: true,
            state_law: StateLaw::default(),
        }
    }
}

impl ForwardModel {
    /// The parameters of the law itself, in reporting order.
    pub(crate) fn law_params(self) -> &'static [Param] {
        match self.law {
            LawKind::AgingRejuvenation => &[Param::Alpha, Param::A, Param::FD, Param::T0],
            LawKind::LogAging => &[Param::A, Param::T0],
            LawKind::RateState => &[Param::A, Param::B, Param::Dc, Param::FD, Param::T0],
        }
    }

    /// Whether a run of `scene` uses parameter `p`. Under a law in interface time a repeat
    /// slide needs no law, only the force it slides at: F_end of the slide it follows
    /// (`follows_slide`), else F_d; it keeps F_d whenever the law has F_d, so that a
    /// contact's F_d is one parameter. Under rate-and-state a repeat slide is a slide of the
    /// same law from the state steady sliding left (docs/model.md §10): every parameter of
    /// the law but the hold age t0.
    pub fn uses(self, p: Param, scene: Scene, follows_slide: bool) -> bool {
        let in_law = self.law_params().contains(&p);
        match p {
            Param::Sigma => true,
            Param::K => self.elastic && scene != Scene::StiffFast,
            Param::T0 if scene == Scene::Repeat => false,
            _ if scene == Scene::Repeat && self.law == LawKind::RateState => in_law,
            Param::FD if scene == Scene::Repeat => in_law || !follows_slide,
            _ => scene != Scene::Repeat && in_law,
        }
    }

    /// Whether `a` is sampled as a/F_d: under `aging = "ratio"`, when a is the aging
    /// amplitude of a law with F_d (not rate-and-state's direct effect, sampled in newtons).
    pub(crate) fn aging_ratio(self, aging: Aging) -> bool {
        aging == Aging::Ratio
            && self.law != LawKind::RateState
            && self.law_params().contains(&Param::FD)
    }
}

impl std::fmt::Display for ForwardModel {
    /// The law as model files name it (with its state law under rate-and-state), and
    /// `, rigid` when the spring is not modelled.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.law.name())?;
        if self.law == LawKind::RateState {
            write!(f, " ({} law)", self.state_law)?;
        }
        if !self.elastic {
            f.write_str(", rigid")?;
        }
        Ok(())
    }
}
