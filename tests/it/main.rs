//! The integration tests, built as one test binary (one link, one process
//! start): each module is the file of the same name. Tests that need a
//! process of their own (memory measured while nothing else allocates) are
//! separate files beside this folder.

mod bounds;
mod bracket;
mod bundles;
mod certificates;
mod cli;
mod common;
mod creased_leaves;
mod csg;
mod deep;
mod derivatives;
mod diagnostics;
mod evaluators;
mod extremes;
mod hostile;
mod hulls;
mod intersect;
mod layering;
mod mesh;
mod mesh_certificate;
mod polynomial;
mod printing;
mod proof;
mod render;
mod scenes;
mod seams;
mod short_tapes;
mod slopes;
mod specialise;
mod steps;
mod vm;
