//! Which attribute channels a bake computes.

use crate::octree::ChannelKind;

/// Which channels to compute.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChannelSelection {
    bits: u8,
}

impl ChannelSelection {
    /// Every channel.
    pub const ALL: Self = Self { bits: 0b11_1111 };
    /// No channel: the tree alone.
    pub const NONE: Self = Self { bits: 0 };

    fn bit(k: ChannelKind) -> u8 {
        1 << ChannelKind::ALL.iter().position(|&c| c == k).unwrap_or(0)
    }

    /// Whether `k` is selected.
    pub fn has(self, k: ChannelKind) -> bool {
        self.bits & Self::bit(k) != 0
    }

    /// With `k` added.
    pub fn with(self, k: ChannelKind) -> Self {
        Self {
            bits: self.bits | Self::bit(k),
        }
    }

    /// With `k` removed.
    pub fn without(self, k: ChannelKind) -> Self {
        Self {
            bits: self.bits & !Self::bit(k),
        }
    }
}

impl std::str::FromStr for ChannelSelection {
    type Err = String;

    /// Parses a comma-separated list of channel names (`all` and `none` too).
    fn from_str(s: &str) -> Result<Self, String> {
        let mut sel = Self::NONE;
        for name in s.split(',').map(str::trim).filter(|n| !n.is_empty()) {
            match name {
                "all" => sel = Self::ALL,
                "none" => {}
                _ => {
                    let k = name.parse::<ChannelKind>().map_err(|_| {
                        let names: Vec<_> = ChannelKind::ALL.iter().map(|k| k.name()).collect();
                        format!(
                            "unknown channel {name:?} (expected: {}, all, none)",
                            names.join(", ")
                        )
                    })?;
                    sel = sel.with(k);
                }
            }
        }
        Ok(sel)
    }
}
