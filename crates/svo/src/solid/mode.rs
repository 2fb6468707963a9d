//! The choice of how a solid bake decides what is inside a mesh (the fill itself is behind
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
}

impl std::str::FromStr for SolidMode {
    type Err = String;

    /// Parses a command-line name: `closed` or `vote`.
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "closed" => Ok(Self::Closed),
            "vote" => Ok(Self::Vote),
            _ => Err(format!("unknown solid mode `{s}` (closed, vote)")),
        }
    }
}
