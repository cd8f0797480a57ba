//! Shared by the `mesh_*` integration tests: an in-memory glTF/GLB builder, an allocation
//! meter, and the checks every rejected file must pass.
#![allow(dead_code)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::time::{Duration, Instant};

use gltf::json::Value;
use subsurface_render::mesh::load_gltf_slice;

/// Longest a load may take, failing or not. Generous for a loaded 2-core debug build; a
/// hang or an exponential walk overshoots it by orders of magnitude.
pub const TIME_LIMIT: Duration = Duration::from_secs(5);

/// Parses a JSON fragment.
pub fn v(s: &str) -> Value {
    gltf::json::deserialize::from_str(s).unwrap_or_else(|e| panic!("{e}: {s}"))
}

pub fn f32_bytes(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

pub fn u16_bytes(v: &[u16]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

pub fn u32_bytes(v: &[u32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

// Shared with the loader's unit tests (src/mesh/gltf.rs), which cannot reach this module.
mod base64;
pub use base64::base64_encode;

/// Component types, as glTF numbers them.
pub const U8: u32 = 5121;
pub const U16: u32 = 5123;
pub const U32: u32 = 5125;
pub const F32: u32 = 5126;

/// A glTF document being built: JSON plus the bytes of its single buffer.
#[derive(Clone)]
pub struct Model {
    pub json: Value,
    pub bin: Vec<u8>,
}

impl Model {
    /// One scene, one node with mesh 0, whose one primitive has no attributes yet.
    pub fn empty() -> Model {
        Model {
            json: v(
                r#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],
                "nodes":[{"mesh":0}],"meshes":[{"primitives":[{"attributes":{}}]}],
                "bufferViews":[],"accessors":[]}"#,
            ),
            bin: vec![],
        }
    }

    /// A unit quad in the xy plane (two triangles): accessors POSITION 0, NORMAL 1,
    /// TEXCOORD_0 2, indices 3 (u16); buffer views 0..=3 likewise.
    pub fn quad() -> Model {
        let mut m = Model::empty();
        let p = [0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.];
        m.attribute("POSITION", &f32_bytes(&p), F32, 4, "VEC3");
        m.attribute(
            "NORMAL",
            &f32_bytes(&[0., 0., 1.].repeat(4)),
            F32,
            4,
            "VEC3",
        );
        let uv = [0., 0., 1., 0., 1., 1., 0., 1.];
        m.attribute("TEXCOORD_0", &f32_bytes(&uv), F32, 4, "VEC2");
        let i = m.accessor(&u16_bytes(&[0, 1, 2, 0, 2, 3]), U16, 6, "SCALAR");
        m.json["meshes"][0]["primitives"][0]["indices"] = i.into();
        m
    }

    /// [`Model::quad`] with a sparse accessor on POSITION: the vertices at `indices` (of
    /// `component` type) move to the positions `values`, three floats each.
    pub fn quad_sparse(indices: &[u8], component: u32, values: &[f32]) -> Model {
        let mut m = Model::quad();
        let idx = m.view(indices);
        let val = m.view(&f32_bytes(values));
        let count = values.len() / 3;
        m.json["accessors"][0]["sparse"] = v(&format!(
            r#"{{"count":{count},"indices":{{"bufferView":{idx},"componentType":{component}}},
            "values":{{"bufferView":{val}}}}}"#
        ));
        m
    }

    /// Appends `value` to the top-level array `key` (created if missing); its index.
    pub fn push(&mut self, key: &str, value: Value) -> usize {
        if !self.json[key].is_array() {
            self.json[key] = v("[]");
        }
        let a = self.json[key].as_array_mut().unwrap();
        a.push(value);
        a.len() - 1
    }

    /// Appends `bytes` (4-aligned) to the buffer as a new buffer view; its index.
    pub fn view(&mut self, bytes: &[u8]) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        let len = bytes.len();
        self.push(
            "bufferViews",
            v(&format!(
                r#"{{"buffer":0,"byteOffset":{offset},"byteLength":{len}}}"#
            )),
        )
    }

    /// A new accessor over a new view of `bytes`; its index. VEC3 float accessors get
    /// the `min`/`max` the crate's validator demands of positions.
    pub fn accessor(&mut self, bytes: &[u8], component: u32, count: u64, ty: &str) -> usize {
        let view = self.view(bytes);
        let mut a = v(&format!(
            r#"{{"bufferView":{view},"componentType":{component},"count":{count},"type":"{ty}"}}"#
        ));
        if ty == "VEC3" && component == F32 {
            a["min"] = v("[0,0,0]");
            a["max"] = v("[1,1,1]");
        }
        self.push("accessors", a)
    }

    /// [`Model::accessor`] bound to attribute `name` of mesh 0 primitive 0.
    pub fn attribute(
        &mut self,
        name: &str,
        bytes: &[u8],
        component: u32,
        count: u64,
        ty: &str,
    ) -> usize {
        let a = self.accessor(bytes, component, count, ty);
        self.json["meshes"][0]["primitives"][0]["attributes"][name] = a.into();
        a
    }

    /// glTF JSON with the buffer as a base64 data URI.
    pub fn gltf(&self) -> Vec<u8> {
        let mut j = self.json.clone();
        if !self.bin.is_empty() {
            j["buffers"] = v(&format!(
                r#"[{{"byteLength":{},"uri":"data:application/octet-stream;base64,{}"}}]"#,
                self.bin.len(),
                base64_encode(&self.bin)
            ));
        }
        gltf::json::serialize::to_vec(&j).unwrap()
    }

    /// Binary glTF with the buffer in the BIN chunk.
    pub fn glb(&self) -> Vec<u8> {
        let mut j = self.json.clone();
        if !self.bin.is_empty() {
            j["buffers"] = v(&format!(r#"[{{"byteLength":{}}}]"#, self.bin.len()));
        }
        glb(&gltf::json::serialize::to_vec(&j).unwrap(), &self.bin)
    }
}

/// Packs a JSON chunk and an optional BIN chunk into a GLB container.
pub fn glb(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let pad = |b: &[u8], with: u8| {
        let mut b = b.to_vec();
        while !b.len().is_multiple_of(4) {
            b.push(with);
        }
        b
    };
    let (json, bin) = (pad(json, b' '), pad(bin, 0));
    let total = 12 + 8 + json.len() + if bin.is_empty() { 0 } else { 8 + bin.len() };
    let mut out = b"glTF".to_vec();
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    if !bin.is_empty() {
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin);
    }
    out
}

/// Loads `bytes`, which must fail quickly with a one-line `SceneError::Gltf` naming
/// `name`; returns the message.
pub fn load_err(bytes: &[u8], name: &str) -> String {
    let t0 = Instant::now();
    let r = load_gltf_slice(bytes, name);
    let dt = t0.elapsed();
    assert!(dt < TIME_LIMIT, "{name}: took {dt:?}");
    let e = match r {
        Ok(m) => panic!(
            "{name}: loaded {} vertices, expected an error",
            m.mesh.vertices.len()
        ),
        Err(e) => e.to_string(),
    };
    eprintln!("{e}");
    assert!(!e.contains('\n'), "{e}");
    let prefix = format!("{name}: not a valid glTF file: ");
    assert!(e.starts_with(&prefix), "{e}");
    e
}

/// [`load_err`], then checks the message contains every one of `parts`.
pub fn expect_err(bytes: &[u8], name: &str, parts: &[&str]) -> String {
    let e = load_err(bytes, name);
    for p in parts {
        assert!(e.contains(p), "{e:?} does not mention {p:?}");
    }
    e
}

/// Counts the allocations of the threads that ask for it (tests run in parallel).
pub struct Meter;

// The test binary's allocator: it counts on the calling thread only, so tests running on
// other threads do not disturb a metered load.
#[global_allocator]
static METER: Meter = Meter;

thread_local! {
    static METERING: Cell<bool> = const { Cell::new(false) };
    static LARGEST: Cell<usize> = const { Cell::new(0) };
    static TOTAL: Cell<usize> = const { Cell::new(0) };
}

fn note(size: usize) {
    let _ = METERING.try_with(|m| {
        if m.get() {
            LARGEST.with(|l| l.set(l.get().max(size)));
            TOTAL.with(|t| t.set(t.get().saturating_add(size)));
        }
    });
}

// SAFETY: forwards every call to `System` unchanged; the bookkeeping touches only
// const-initialised thread-locals, which never allocate.
unsafe impl GlobalAlloc for Meter {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(new_size);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// Runs `f` and returns its result with the largest single allocation and the total
/// bytes allocated on this thread meanwhile.
pub fn metered<R>(f: impl FnOnce() -> R) -> (R, usize, usize) {
    LARGEST.with(|l| l.set(0));
    TOTAL.with(|t| t.set(0));
    METERING.with(|m| m.set(true));
    let r = f();
    METERING.with(|m| m.set(false));
    (r, LARGEST.with(Cell::get), TOTAL.with(Cell::get))
}
