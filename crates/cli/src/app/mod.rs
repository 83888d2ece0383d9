//! The application layer: what the command-line program and the Python package both stand on.
//!
//! Each room holds one concern, and data flows through them one way:
//! - [`input`]: the user's files read with a bound on their size;
//! - [`setup`]: the setup resolved once (the setup file, a URDF and its meshes, actuators,
//!   sensors, model errors) into the core's types;
//! - [`studies`]: plan, simulate and the other studies, typed options in, typed results out,
//!   nothing written;
//! - [`formats`]: one room per file kind (PGN, plots, the replay page, the hardware export, the
//!   URDF export, the studies' tables);
//! - [`bus`]: the servo bus (packets, driver, simulated bus, the real arm), which depends on the
//!   physics only;
//! - [`output`]: result files written whole or not at all, the folder's list, its lock;
//! - [`resources`]: the bounds on memory and work a run is held to;
//! - [`shutdown`]: what a termination signal undoes, registered by the rooms that hold it;
//! - [`text`]: text from a user, a file or an engine shown safely on one line.
//!
//! The binary's `commands` and the Python bindings call these rooms; no room here imports the
//! binary's argument parser or its commands.

pub mod bus;
pub mod formats;
pub mod input;
pub mod output;
pub mod resources;
pub mod setup;
pub mod shutdown;
pub mod studies;
pub mod text;
