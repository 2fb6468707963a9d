//! Where the voxelizer runs each overlap test: the thesis's table rows and our default.

use std::fmt;
use std::str::FromStr;

/// Which overlap tests run at which level of the octree build. Every strategy classifies
/// triangles into children by their bounding boxes (thesis Algorithm 1) at every level.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Strategy {
    /// Bounding boxes and the plane test at every level; no edge axes. Inexact: a superset.
    AabbPlane,
    /// Bounding boxes, plane and edge axes at every level. Exact.
    AabbPlaneSat,
    /// Bounding boxes at every level; the thesis's SAT (edge axes only, no plane axis) at the
    /// leaves. Inexact: a superset, as in the thesis.
    SatLeaf,
    /// Bounding boxes and plane at every level, edge axes at the leaves. Exact.
    PlaneSatLeaf,
    /// The default: the fastest exact placement measured (`docs/benchmarks.md`). Today that
    /// is the vertex-inside shortcut, the plane and the edge axes at every level, with the
    /// plane and vertex tests computed once per node for all eight children.
    #[default]
    Exact,
}

impl Strategy {
    /// All strategies, in the thesis's table order, then the default.
    pub const ALL: [Strategy; 5] = [
        Self::AabbPlane,
        Self::AabbPlaneSat,
        Self::SatLeaf,
        Self::PlaneSatLeaf,
        Self::Exact,
    ];

    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Self::AabbPlane => "aabb-plane",
            Self::AabbPlaneSat => "aabb-plane-sat",
            Self::SatLeaf => "sat-leaf",
            Self::PlaneSatLeaf => "plane-sat-leaf",
            Self::Exact => "exact",
        }
    }

    /// Whether the strategy produces exactly the cells that the triangles touch (the
    /// others produce supersets).
    pub fn is_exact(self) -> bool {
        matches!(self, Self::AabbPlaneSat | Self::PlaneSatLeaf | Self::Exact)
    }
}

impl fmt::Display for Strategy {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Strategy {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .iter()
            .copied()
            .find(|k| k.name() == s)
            .ok_or_else(|| {
                let names: Vec<_> = Self::ALL.iter().map(|k| k.name()).collect();
                format!(
                    "unknown strategy {s:?} (expected one of: {})",
                    names.join(", ")
                )
            })
    }
}
