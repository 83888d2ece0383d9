//! The live loop's pieces (`play --human`) the binary keeps: the person's input ([`input`]: the
//! terminal, a file, a socket) and the live page ([`page`]). The person's turns are the
//! layer's (`app::studies::person`).

pub mod input;
pub mod page;
