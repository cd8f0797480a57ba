//! One test binary for the subsurface command's tests: each file beside this one is a module.
//! Every file under tests/ used to link into a binary of its own; together they
//! took gigabytes (Bevy's were 170 MB each) and a CI machine ran out of disk.
//! `subsurface-render`'s `main.rs` checks that every file here is declared below.
//! Run one file's tests with its module path: `cargo test --test integration <file>::`.

mod common;

mod cli;
mod cli_extremes;
mod cli_outputs;
mod fidelity;
mod hardening2;
mod suite_guard;
mod view;
