//! Paper 004's Tables 1-3 as printed, and the trackers compared.

/// Paper 004 Table 1 (MAD tracker): `(frame, x, y)`.
pub const PAPER_TABLE1: [(usize, f64, f64); 10] = [
    (1, 58.0, 83.0),
    (4, 64.0, 93.0),
    (7, 69.0, 102.0),
    (10, 75.0, 112.0),
    (13, 76.0, 112.0),
    (16, 76.0, 113.0),
    (19, 76.0, 113.0),
    (22, 76.0, 113.0),
    (25, 76.0, 113.0),
    (28, 76.0, 112.0),
];

/// Paper 004 Table 2 (PF tracker): `(frame, x, y)`.
pub const PAPER_TABLE2: [(usize, f64, f64); 10] = [
    (1, 57.0, 85.0),
    (4, 65.0, 100.0),
    (7, 72.0, 115.0),
    (10, 80.0, 130.0),
    (13, 88.0, 145.0),
    (16, 95.0, 160.0),
    (19, 103.0, 175.0),
    (22, 111.0, 190.0),
    (25, 119.0, 205.0),
    (28, 126.0, 220.0),
];

/// Paper 004 Table 3: `(frame, [x, y, Lx, Ly] of target 1, of target 2)`.
pub const PAPER_TABLE3: [(usize, [f64; 4], [f64; 4]); 8] = [
    (42, [146.0, 159.0, 34.0, 46.0], [186.0, 141.0, 29.0, 43.0]),
    (45, [159.0, 165.0, 33.0, 48.0], [198.0, 147.0, 30.0, 44.0]),
    (46, [163.0, 168.0, 33.0, 47.0], [201.0, 149.0, 30.0, 44.0]),
    (49, [173.0, 173.0, 35.0, 51.0], [214.0, 155.0, 32.0, 47.0]),
    (50, [177.0, 175.0, 36.0, 51.0], [219.0, 157.0, 32.0, 46.0]),
    (51, [181.0, 177.0, 37.0, 52.0], [224.0, 159.0, 33.0, 48.0]),
    (52, [186.0, 178.0, 38.0, 53.0], [228.0, 160.0, 35.0, 48.0]),
    (53, [189.0, 181.0, 39.0, 54.0], [232.0, 163.0, 35.0, 50.0]),
];

/// The single-target trackers compared in Tables 1-2, in column order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Variant {
    /// MAD tracker searching a window around its last match.
    MadWindow,
    /// MAD tracker searching the whole frame.
    MadFrame,
    /// PF with eq. 6 as printed (`A = 1`: a random walk).
    PfPrinted,
    /// PF with the ARP on the displacement ([`ArpMotion::Drift`](bayestrack_trackers::ArpMotion::Drift)).
    PfDrift,
    /// PF with the displacement ARP and a capped MAD in eq. 7 (not in the paper).
    PfDriftCap,
    /// PF with a constant drift measured by the MAD match between frames 1
    /// and 2, the particle filter from frame 3 on (sec. 3.2;
    /// [`ArpMotion::ConstantDrift`](bayestrack_trackers::ArpMotion::ConstantDrift)), eq. 7 as printed.
    PfConstDrift,
}

impl Variant {
    /// Every variant, in column order.
    pub const ALL: [Variant; 6] = [
        Variant::MadWindow,
        Variant::MadFrame,
        Variant::PfPrinted,
        Variant::PfDrift,
        Variant::PfDriftCap,
        Variant::PfConstDrift,
    ];

    /// Column label.
    pub fn name(self) -> &'static str {
        match self {
            Variant::MadWindow => "MAD window",
            Variant::MadFrame => "MAD frame",
            Variant::PfPrinted => "PF eq.6 printed",
            Variant::PfDrift => "PF drift",
            Variant::PfDriftCap => "PF drift+cap",
            Variant::PfConstDrift => "PF const drift",
        }
    }

    /// Whether it is one of the particle filters.
    pub fn is_pf(self) -> bool {
        !matches!(self, Variant::MadWindow | Variant::MadFrame)
    }
}
