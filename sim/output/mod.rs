//! What the host writes and shows: dataset folders, rerun recordings, pictures, and maps rendered at given poses.

pub(crate) mod canvas;
pub mod dataset;
pub mod novel_view;
pub mod plot;
pub mod rerun_log;
