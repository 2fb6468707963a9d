//! The choice of how a solid bake decides what is inside a mesh (see `solid_fill.rs`, behind
//! the `solid` feature).

/// How the inside of a mesh is decided.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum SolidMode {
    /// Closed meshes only (others are refused): crossing parity along z columns, exact.
    Closed,
    /// Meshes with holes: crossing parity along x, y and z columns, columns with an odd
    /// number of crossings abstaining, the majority of the others deciding.
    Vote,
}

impl SolidMode {
    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Closed => "closed",
            Self::Vote => "vote",
        }
    }

    /// Parses a command-line name.
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "closed" => Some(Self::Closed),
            "vote" => Some(Self::Vote),
            _ => None,
        }
    }
}
