//! The filters of the table and paper 000's and van der Merwe et al.'s numbers.

/// The filters of the table, in row order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FilterKind {
    /// Extended Kalman filter alone.
    Ekf,
    /// Unscented Kalman filter alone (augmented state).
    Ukf,
    /// Bootstrap particle filter (transition prior as proposal).
    Pf,
    /// Bootstrap PF with a Metropolis-Hastings move.
    PfMcmc,
    /// PF with EKF proposals.
    PfEkf,
    /// PF-EKF with a Metropolis-Hastings move.
    PfEkfMcmc,
    /// PF with UKF proposals (the unscented particle filter).
    PfUkf,
    /// PF-UKF with a Metropolis-Hastings move.
    PfUkfMcmc,
    /// PF with IEKF proposals.
    PfIekf,
    /// PF with the hybrid UKF -> IEKF proposal (paper 000).
    Hikpf,
}

impl FilterKind {
    /// Every filter, in row order.
    pub const ALL: [FilterKind; 10] = [
        FilterKind::Ekf,
        FilterKind::Ukf,
        FilterKind::Pf,
        FilterKind::PfMcmc,
        FilterKind::PfEkf,
        FilterKind::PfEkfMcmc,
        FilterKind::PfUkf,
        FilterKind::PfUkfMcmc,
        FilterKind::PfIekf,
        FilterKind::Hikpf,
    ];

    /// Row label.
    pub fn name(self) -> &'static str {
        match self {
            FilterKind::Ekf => "EKF",
            FilterKind::Ukf => "UKF",
            FilterKind::Pf => "PF",
            FilterKind::PfMcmc => "PF-MCMC",
            FilterKind::PfEkf => "PF-EKF",
            FilterKind::PfEkfMcmc => "PF-EKF-MCMC",
            FilterKind::PfUkf => "PF-UKF",
            FilterKind::PfUkfMcmc => "PF-UKF-MCMC",
            FilterKind::PfIekf => "PF-IEKF",
            FilterKind::Hikpf => "HIKPF",
        }
    }

    /// Paper 000 Table 1: (mean, variance) of the per-run error.
    pub fn paper(self) -> Option<(f64, f64)> {
        match self {
            FilterKind::Pf => Some((0.25881, 0.057151)),
            FilterKind::PfEkf => Some((0.32392, 0.021656)),
            FilterKind::PfUkf => Some((0.077684, 0.006589)),
            FilterKind::PfIekf => Some((0.049368, 0.0015238)),
            FilterKind::Hikpf => Some((0.015607, 0.00000395)),
            _ => None,
        }
    }

    /// Van der Merwe et al. 2000, Table 1: mean of the per-run error
    /// (approximate, as transcribed in SPEC section 3).
    pub fn van_der_merwe(self) -> Option<f64> {
        match self {
            FilterKind::Ekf => Some(0.374),
            FilterKind::Ukf => Some(0.280),
            FilterKind::Pf => Some(0.424),
            FilterKind::PfMcmc => Some(0.417),
            FilterKind::PfEkf => Some(0.310),
            FilterKind::PfEkfMcmc => Some(0.307),
            FilterKind::PfUkf => Some(0.070),
            FilterKind::PfUkfMcmc => Some(0.074),
            _ => None,
        }
    }
}
