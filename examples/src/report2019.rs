//! The 2019 report's scene (its section 3.2 and figure 9), built with the programmatic
//! builder ([`Octree::from_fn`]): a voxel box whose outer layer is glass panes in a
//! solid frame, with a void hole in the middle of each pane and no pane at the front, and a
//! semi-solid cube in the middle of the otherwise void interior; lit by three coloured point
//! lights (red between the box and the camera, blue off to the left, green inside the box in
//! the bottom corner nearest the camera).
//!
//! The report's rules, with all sizes as fractions of the box's half-side ("radius") and the
//! regions square (the report builds them with per-axis loops):
//!
//! * the outer layer of cells is glass where the cell lies within 87.5% of the face's centre
//!   (on both in-face axes), solid frame elsewhere;
//! * within 25% of the face's centre the pane has a void hole;
//! * the front face (towards `+z`, the camera) has no pane: only its frame;
//! * inside, a semi-solid cube of radius 12.5%.
//!
//! Materials from the report's table 1 ([`Preset`]): glass `kr 0.2, kt 0.8,
//! IOR 1.5`, semi-solid `kr 0.3, kt 0.2, IOR 1.5`, solid `kr 0.2, kt 0`; void is no voxel.
//! No voxel stores a normal, so glass and semi-solid form volumetric media (the
//! report's "hit where the material changes") and solid cells show their faces.

use glam::{DVec3, UVec3, Vec3};
use svo::mesh::{Preset, SceneInfo, StoredCamera, StoredLight};
use svo::render::{Camera, PointLight};
use svo::{Octree, OctreeError, RootCube, Voxel};

/// The scene: the tree (root `[-1, 1]^3`), its lights and the camera of the report's
/// renderings.
#[derive(Clone, Debug)]
pub struct ReportScene {
    /// The voxel box.
    pub tree: Octree,
    /// Red, blue and green point lights.
    pub lights: Vec<PointLight>,
    /// Looking at the open front of the box, slightly from above and the right.
    pub camera: Camera,
}

/// What a cell of the box is made of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReportMaterial {
    /// The outer frame.
    Solid,
    /// A pane.
    Glass,
    /// The centre cube.
    SemiSolid,
}

impl ReportMaterial {
    /// The preset of this material.
    pub fn preset(self) -> Preset {
        match self {
            Self::Solid => Preset::Solid,
            Self::Glass => Preset::Glass,
            Self::SemiSolid => Preset::SemiSolid,
        }
    }

    /// The voxel for this material (the preset's, white).
    pub fn voxel(self) -> Voxel {
        Voxel::preset(self.preset(), None).unwrap_or_default()
    }
}

/// The material of cell `c` of a box of `n` cells per side by the report's rules, `None`
/// for void.
pub fn report_material(c: UVec3, n: u32) -> Option<ReportMaterial> {
    // Cell centres in [-1, 1].
    let u = (c.as_dvec3() + DVec3::splat(0.5)) / f64::from(n) * 2.0 - DVec3::ONE;
    let on = |a: usize| c[a] == 0 || c[a] == n - 1;
    let outer = (0..3).any(on);
    if !outer {
        return (u.abs().max_element() <= 0.125).then_some(ReportMaterial::SemiSolid);
    }
    // A cell on several faces (an edge or corner of the box) is frame: it is at the edge of
    // every face it lies on.
    let faces: Vec<usize> = (0..3).filter(|&a| on(a)).collect();
    if faces.len() > 1 {
        return Some(ReportMaterial::Solid);
    }
    let a = faces[0];
    let r = (0..3)
        .filter(|&b| b != a)
        .map(|b| u[b].abs())
        .fold(0.0, f64::max);
    if r > 0.875 {
        return Some(ReportMaterial::Solid);
    }
    let front = a == 2 && c.z == n - 1;
    if front || r <= 0.25 {
        None
    } else {
        Some(ReportMaterial::Glass)
    }
}

impl ReportScene {
    /// The lights and the camera (as the view `report`) for the `.svo` file, so a viewer
    /// shows the report's view.
    pub fn scene_info(&self) -> SceneInfo {
        let c = &self.camera;
        SceneInfo {
            lights: self
                .lights
                .iter()
                .map(|l| StoredLight {
                    position: l.position.to_array(),
                    colour: l.colour.to_array(),
                    intensity: l.intensity,
                })
                .collect(),
            cameras: vec![StoredCamera {
                name: "report".into(),
                eye: c.eye.to_array(),
                target: c.target.to_array(),
                up: c.up.to_array(),
                fov_deg: c.fov_deg,
            }],
        }
    }
}

/// Builds the scene with `2^depth` cells per side, for a `width` x `height` image.
pub fn report_scene(depth: u8, width: u32, height: u32) -> Result<ReportScene, OctreeError> {
    let root = RootCube {
        origin: DVec3::splat(-1.0),
        side: 2.0,
    };
    let n = 1u32 << depth.min(31);
    let tree = Octree::from_fn(
        root,
        depth,
        |_, _| true,
        |c| report_material(c, n).map(ReportMaterial::voxel),
    )?;
    let lights = vec![
        PointLight {
            position: DVec3::new(0.35, 0.25, 1.7),
            colour: Vec3::new(1.0, 0.15, 0.1),
            intensity: 1.2,
        },
        PointLight {
            position: DVec3::new(-2.2, 0.9, 1.6),
            colour: Vec3::new(0.15, 0.3, 1.0),
            intensity: 5.0,
        },
        PointLight {
            position: DVec3::new(-0.7, -0.75, 0.75),
            colour: Vec3::new(0.1, 1.0, 0.2),
            intensity: 0.35,
        },
    ];
    let camera = Camera {
        eye: DVec3::new(1.1, 0.9, 3.6),
        target: DVec3::new(0.0, -0.05, 0.0),
        up: DVec3::Y,
        fov_deg: 45.0,
        width,
        height,
    };
    Ok(ReportScene {
        tree,
        lights,
        camera,
    })
}
