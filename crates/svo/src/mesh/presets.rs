//! Material presets: the 2019 report's table 1 (void, glass, semi-solid, solid) and water,
//! in this tracer's model (local Phong light weighs `1 - reflectivity - refractivity`). The
//! report's glass reflectivity of 0.3 would make reflectivity and refractivity exceed one
//! together, so glass reflects 0.2. Scene files, the programmatic builder's presets
//! ([`crate::octree::builder::Voxel`]) and the report's scene all take their values from here.

use crate::mesh::triangle_mesh::Material;

/// A named material preset.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Preset {
    /// Nothing: an object made of void is left out.
    Void,
    /// Reflectivity 0.2, refractivity 0.8, IOR 1.5.
    Glass,
    /// Reflectivity 0.3, refractivity 0.2, IOR 1.5.
    SemiSolid,
    /// Reflectivity 0.2, opaque.
    Solid,
    /// Reflectivity 0.05, refractivity 0.95, IOR 1.33, a blue-green tint.
    Water,
}

impl Preset {
    /// Every preset.
    pub const ALL: [Preset; 5] = [
        Self::Void,
        Self::Glass,
        Self::SemiSolid,
        Self::Solid,
        Self::Water,
    ];

    /// The name in scene files.
    pub fn name(self) -> &'static str {
        match self {
            Self::Void => "void",
            Self::Glass => "glass",
            Self::SemiSolid => "semi-solid",
            Self::Solid => "solid",
            Self::Water => "water",
        }
    }

    /// The preset of a name.
    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == s)
    }

    /// The material (white unless the preset has a tint); `None` for void.
    pub fn material(self) -> Option<Material> {
        let m = |colour: [f32; 4], reflectivity: f32, refractivity: f32, ior: f32| Material {
            name: self.name().to_string(),
            colour,
            texture: None,
            reflectivity,
            refractivity,
            ior,
            alpha_blend: false,
        };
        const WHITE: [f32; 4] = [1.0, 1.0, 1.0, 1.0];
        match self {
            Self::Void => None,
            Self::Glass => Some(m(WHITE, 0.2, 0.8, 1.5)),
            Self::SemiSolid => Some(m(WHITE, 0.3, 0.2, 1.5)),
            Self::Solid => Some(m(WHITE, 0.2, 0.0, 1.5)),
            Self::Water => Some(m([0.6, 0.8, 0.9, 1.0], 0.05, 0.95, 1.33)),
        }
    }
}
