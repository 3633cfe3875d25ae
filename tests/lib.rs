//! Integration tests of the host, compiled into one binary (one link, shared helpers).

mod bad_input;
mod dataset;
mod drive;
mod egl;
mod episode;
mod fair;
mod library;
mod lost_work;
mod nothing_lost;
mod planners;
mod recording;
mod scene;
mod sensor;
mod support;
mod survey;
mod sweep;
mod worlds;
