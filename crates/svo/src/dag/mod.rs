//! Compact geometry: a tree's nodes as a directed acyclic graph, identical subtrees stored
//! once ([`Dag`]). The leaves' values stay in the tree's arrays, in Morton order; each node
//! of the graph counts the leaves below it, so a walk finds a leaf's index.

mod build;

pub use build::Dag;
