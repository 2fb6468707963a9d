//! The weighted sums that a leaf's attributes are the means of, carried up the build so
//! that every inner node gets the attributes of the surface inside its cell.
//!
//! A leaf's values are means over its contacts (a triangle's part in the cell), weighted by
//! the part's area, or equally where every part has zero area
//! ([`crate::attributes::leaf_attributes`]). The parts of a node's children partition the
//! node's surface (a part lying on a face between two children counts in both), so the
//! node's area-weighted sums are the sum of its children's: a node's normal, colour,
//! reflectivity, refractivity and IOR are the area-weighted means over every part below it,
//! textures sampled at the leaves' parts, not means of its children's rounded values.
//! Children whose parts all have zero area add nothing when a sibling has area; when none
//! has, the node takes the equally weighted sums of all of them, as a leaf does.
//!
//! The sums are added in child order, as the records come up the build, so they are the
//! same whatever the thread count and however the tree was cut into parts.

use crate::attributes::leaf_attributes::AttributeInputs;
use crate::octree::encoding::{encode_colour, ior_encode, unorm8};
use crate::octree::layout;
use crate::octree::normal_encoding;
use glam::DVec3;

/// The sums of a node's (or a leaf's) surface, see the module docs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct SurfaceSums {
    /// The parts' area.
    pub area: f64,
    /// The weights' sum: `area` where it is positive, else the number of contacts.
    pub weight: f64,
    /// The weighted sum of the triangles' unit normals.
    pub normal: DVec3,
    /// The direction the node's normal was encoded from: `normal`, or where opposite sheets
    /// cancel, the direction of the heaviest contact (a leaf) or child (a node).
    pub direction: DVec3,
    /// The weighted sum of the linear RGBA colours.
    pub colour: [f64; 4],
    /// The weighted sums of reflectivity, refractivity and IOR.
    pub reflectivity: f64,
    /// See `reflectivity`.
    pub refractivity: f64,
    /// See `reflectivity`.
    pub ior: f64,
    /// The `direction` of the child of largest weight (the first of equals) among those
    /// added: a node's fallback normal.
    pub heaviest: DVec3,
    /// Its weight.
    pub heaviest_weight: f64,
}

impl SurfaceSums {
    fn add_all(&mut self, c: &Self) {
        if c.weight > self.heaviest_weight {
            self.heaviest_weight = c.weight;
            self.heaviest = c.direction;
        }
        self.area += c.area;
        self.weight += c.weight;
        self.normal += c.normal;
        for (a, b) in self.colour.iter_mut().zip(c.colour) {
            *a += b;
        }
        self.reflectivity += c.reflectivity;
        self.refractivity += c.refractivity;
        self.ior += c.ior;
    }

    /// The encoded normal of a node with these sums, choosing its `direction` (see
    /// [`Self::direction`]); `heaviest` is the fallback where the sum cancels.
    pub(crate) fn encode_normal(&mut self, heaviest: impl FnOnce() -> DVec3) -> u32 {
        // `|s| > floor`, decided without a square root where it clearly holds (a floor
        // above 1e-150 squares without underflow; twice it absorbs the rounding).
        let s = self.normal;
        let floor = 1e-12 * self.area.max(1e-300);
        let clear = floor > 1e-150 && s.length_squared() > 4.0 * floor * floor;
        self.direction = if !clear && !(s.length() > floor) {
            // Opposite sheets cancel.
            heaviest()
        } else {
            s
        };
        normal_encoding::encode(self.direction.as_vec3())
    }

    /// The mean colour, RGBA8 sRGB.
    pub(crate) fn encode_colour(&self) -> u32 {
        let ws = if self.weight > 0.0 { self.weight } else { 1.0 };
        encode_colour(self.colour.map(|v| (v / ws) as f32))
    }

    /// The mean reflectivity, refractivity and IOR, encoded.
    pub(crate) fn encode_optics(&self) -> (u8, u8, u16) {
        let mean = |a: f64| {
            if self.weight > 0.0 {
                (a / self.weight) as f32
            } else {
                0.0
            }
        };
        (
            unorm8(mean(self.reflectivity)),
            unorm8(mean(self.refractivity)),
            ior_encode(mean(self.ior)),
        )
    }
}

impl layout::Sums for SurfaceSums {
    /// Adds a child's sums: area-weighted children only once one has area, see the module
    /// docs.
    fn add(&mut self, c: &Self) {
        if c.area > 0.0 {
            if !(self.area > 0.0) {
                // The equally weighted sums so far give way to the area-weighted ones.
                *self = Self::default();
            }
            self.add_all(c);
        } else if !(self.area > 0.0) {
            self.add_all(c);
        }
    }
}

/// What a bake carries up its build: [`SurfaceSums`] and each node's [`NodeValue`] where the
/// inner nodes' attributes are made, nothing (`()`, at no cost) where they are not.
pub(crate) trait BakeSums: layout::Sums {
    /// What a node stores beside its record.
    type Value: Copy + Default + Send + Sync + std::fmt::Debug;
    /// The sums of a leaf.
    fn of_leaf(s: SurfaceSums) -> Self;
    /// A node's value from its children's sums (which it completes).
    fn value(inputs: &AttributeInputs<'_>, s: &mut Self) -> Self::Value;
}

impl BakeSums for () {
    type Value = ();
    fn of_leaf(_: SurfaceSums) {}
    fn value(_: &AttributeInputs<'_>, _: &mut ()) {}
}

impl BakeSums for SurfaceSums {
    type Value = NodeValue;
    fn of_leaf(s: SurfaceSums) -> Self {
        s
    }
    fn value(inputs: &AttributeInputs<'_>, s: &mut Self) -> NodeValue {
        inputs.node_value(s)
    }
}

impl SurfaceSums {
    /// The sums as 19 numbers (area, weight, normal, direction, colour, reflectivity,
    /// refractivity, IOR, heaviest, its weight), as a part file carries a subtree's.
    #[cfg(feature = "io")]
    pub(crate) fn to_words(self) -> Vec<f64> {
        let mut v = vec![self.area, self.weight];
        v.extend(self.normal.to_array());
        v.extend(self.direction.to_array());
        v.extend(self.colour);
        v.extend([self.reflectivity, self.refractivity, self.ior]);
        v.extend(self.heaviest.to_array());
        v.push(self.heaviest_weight);
        v
    }

    /// The sums of [`Self::to_words`]'s numbers (`None` unless there are 19).
    #[cfg(feature = "io")]
    pub(crate) fn from_words(w: &[f64]) -> Option<Self> {
        let w: &[f64; 19] = w.try_into().ok()?;
        let v3 = |i: usize| DVec3::new(w[i], w[i + 1], w[i + 2]);
        Some(Self {
            area: w[0],
            weight: w[1],
            normal: v3(2),
            direction: v3(5),
            colour: [w[8], w[9], w[10], w[11]],
            reflectivity: w[12],
            refractivity: w[13],
            ior: w[14],
            heaviest: v3(15),
            heaviest_weight: w[18],
        })
    }
}

/// Which values a node's sums are encoded into: the normal where the leaves' normals or
/// contours are made, and the colour and the materials where they vary over the leaves (else
/// they are constants, and a node's is the leaves').
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "io", derive(serde::Serialize, serde::Deserialize))]
pub(crate) struct NodeRule {
    /// The normal.
    pub normal: bool,
    /// The colour.
    pub colour: bool,
    /// Reflectivity, refractivity and IOR.
    pub optics: bool,
}

impl NodeRule {
    /// The value of a node whose children's sums added up to `sums` (which it completes: the
    /// direction its normal was encoded from).
    pub(crate) fn value(self, sums: &mut SurfaceSums) -> NodeValue {
        let mut v = NodeValue::default();
        if self.normal {
            let heaviest = sums.heaviest;
            v.normal = sums.encode_normal(|| heaviest);
        }
        if self.colour {
            v.colour = sums.encode_colour();
        }
        if self.optics {
            (v.reflectivity, v.refractivity, v.ior) = sums.encode_optics();
        }
        v
    }
}

/// A node's encoded attributes, as the build stores them beside its record (the contour
/// comes later, from the finished tree: [`crate::attributes::node_attributes`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "io", derive(serde::Serialize, serde::Deserialize))]
pub(crate) struct NodeValue {
    /// Octahedral normal.
    pub normal: u32,
    /// RGBA8 sRGB.
    pub colour: u32,
    /// Unorm8.
    pub reflectivity: u8,
    /// Unorm8.
    pub refractivity: u8,
    /// Encoded IOR.
    pub ior: u16,
}
