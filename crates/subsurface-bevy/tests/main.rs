//! One test binary for the Bevy plugin's tests: each file beside this one is a module.
//! Every file under tests/ used to link into a binary of its own; together they
//! took gigabytes (Bevy's were 170 MB each) and a CI machine ran out of disk.
//! `subsurface-render`'s `main.rs` checks that every file here is declared below.
//! Run one file's tests with its module path: `cargo test --test integration <file>::`.

mod common;

mod headless;
mod oracle;
mod scatter;
mod shadow_edge;
mod shadow_maps;
mod timing;
mod transmittance;
mod two_cameras;
