//! The C ABI's integration tests (one binary): the panic boundary on every export, bad input, and the
//! C program driving a controller through a recorded sensor log.

mod c_program;
mod common;
mod exports;
