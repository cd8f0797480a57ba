//! One test binary for subsurface-render's GPU and input tests: each file beside this one is a module.
//! Every file under tests/ used to link into a binary of its own; together they
//! took gigabytes (Bevy's were 170 MB each) and a CI machine ran out of disk.
//! The test at the end checks that every crate's `main.rs` declares all its files.
//! Run one file's tests with its module path: `cargo test --test integration <file>::`.

mod common;
mod mesh_util;
mod sss_util;

mod bounce;
mod extremes;
mod fuzz_inputs;
mod gpu;
mod lit_side;
mod mesh_fuzz;
mod mesh_hardening;
mod outline;
mod profiles;
mod reference;
mod shadow_entry;
mod side_walls;
mod skin_in_your_renderer;
mod specular;
mod sss;
mod texture_space;
mod thin_parts;
mod transmittance;

/// With `autotests = false` a new file under a crate's tests/ would silently never run: each
/// crate's `tests/main.rs` must declare every file beside it.
#[test]
fn every_test_file_is_a_module_of_its_crates_main() {
    let crates = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    for name in ["subsurface-render", "subsurface-cli", "subsurface-bevy"] {
        let dir = crates.join(name).join("tests");
        let main = std::fs::read_to_string(dir.join("main.rs")).unwrap();
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            let stem = path.file_stem().unwrap().to_string_lossy().into_owned();
            if path.extension().is_some_and(|e| e == "rs") && stem != "main" {
                let declared = main.contains(&format!("\nmod {stem};\n"));
                assert!(declared, "{name}/tests/main.rs lacks `mod {stem};`");
            }
        }
    }
}
