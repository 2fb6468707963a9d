//! Rays through the octree, on the CPU, as the GPU traces them: [`Octree::cast`],
//! [`Octree::cast_with`] and [`Octree::cast_many`] in scene units ([`Ray`], [`Hit`]), and beneath them the
//! pieces a renderer or a GPU port builds on:
//!
//! - [`GridRay`]: a ray in the tree's grid space (`f32`, as the GPU has it), mirrored into
//!   the positive octant for the walk, with `-0.0` and tiny components made safe;
//! - [`traverse`]: the one traversal (Revelles et al.'s parametric walk, front to back), which
//!   hands each leaf the ray enters to a callback ([`LeafEntry`]) until it returns a value;
//! - [`leaf_hit`] and [`cast`]: the cube and contour hits inside a leaf, as callbacks;
//! - [`Cone`] and [`traverse_cone`]: a ray's footprint, and the walk that stops at an inner
//!   node as wide as the footprint (level of detail) and hands it over in place of its leaves;
//! - [`DenseGrid`] and [`traverse_dda`]: a dense grid of the same leaves walked by 3D DDA, the
//!   baseline the octree is measured against.
//!
//! ```
//! use glam::{DVec3, UVec3};
//! use svo::trace::{GridRay, MAX_STEPS, traverse};
//! use svo::{Octree, RootCube, Voxel};
//! // A row of four cells along x; a ray along it sees every one, front to back.
//! let root = RootCube { origin: DVec3::ZERO, side: 4.0 };
//! let cells = (0..4).map(|x| (UVec3::new(x, 1, 1), Voxel::default()));
//! let tree = Octree::from_cells(root, 2, cells)?;
//! let ray = GridRay::from_scene(&tree.root, tree.depth, DVec3::new(-1.0, 1.5, 1.5), DVec3::X);
//! let mut seen = Vec::new();
//! let walk = traverse(&tree, &ray, 0.0, f32::INFINITY, MAX_STEPS, |leaf| {
//!     seen.push((leaf.cell.x, leaf.t_enter));
//!     None::<()> // go on; `Some` stops the walk and is returned
//! });
//! assert_eq!(seen, [(0, 1.0), (1, 2.0), (2, 3.0), (3, 4.0)]);
//! assert!(walk.hit.is_none() && !walk.capped);
//! # Ok::<(), svo::OctreeError>(())
//! ```
//!
//! The traversal never misses a leaf the ray enters (the brute-force tests check it for
//! axis-parallel rays, `-0.0`, rays through corners and edges, and deep trees). Shading,
//! cameras and images are [`crate::render`]'s. Depends on [`crate::octree`] and the grid
//! geometry only.
//!
//! [`Octree::cast`]: crate::Octree::cast
//! [`Octree::cast_with`]: crate::Octree::cast_with
//! [`Octree::cast_many`]: crate::Octree::cast_many

pub(crate) mod cast;
pub(crate) mod cone;
pub(crate) mod dda;
pub(crate) mod grid_ray;
pub(crate) mod leaf_hit;
pub(crate) mod packet;
pub(crate) mod traverse;

pub use cast::{Hit, Ray};
pub use cone::Cone;
pub use dda::{DdaError, DenseGrid, MAX_DDA_DEPTH, traverse_dda};
pub use grid_ray::{GridRay, TINY};
pub use leaf_hit::{HitMode, LeafHit, cast, leaf_hit};
pub use packet::{LANES, traverse_packet};
pub use traverse::{LeafEntry, MAX_STEPS, Traversal, traverse, traverse_cone};
