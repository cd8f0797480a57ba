//! Checks that make the `gltf` crate safe to use on untrusted files.
//!
//! The crate's accessor reader trusts the file: it computes byte ranges with unchecked
//! arithmetic (a panic in debug builds), yields `count` zeros for a sparse accessor without a
//! buffer view (600 M vertices from a 700-byte file), hits `unreachable!()` for component
//! types it does not expect, and returns `None` - which callers read as "attribute absent" -
//! when a range lies outside its buffer. Its validator indexes `accessors[POSITION]` before
//! checking the index, and its URI decoder unwraps. Everything here runs before the
//! corresponding crate call, so the crate only ever sees input it handles, and every
//! failure becomes a message for `SceneError::Gltf`.

use std::path::{Path, PathBuf};

use glam::Mat4;
use gltf::accessor::{DataType, Dimensions};

/// Most vertices one glTF file may produce (all primitives of all node instances): 16 Mi,
/// about 800 MB as [`Vertex`](super::Vertex). Checked before anything is allocated.
pub const MAX_GLTF_VERTICES: usize = 16 << 20;
/// Most indices one glTF file may produce (16 Mi triangles).
pub const MAX_GLTF_INDICES: usize = 48 << 20;
/// Deepest node hierarchy accepted. Traversal is iterative, so this is not about the stack:
/// real skeletons are a few dozen levels deep, and anything far beyond is generated junk.
pub const MAX_NODE_DEPTH: usize = 256;
/// Most node instances (a node reached through `k` paths counts `k` times). Bounds the
/// work of a small node graph that branches into exponentially many paths.
pub const MAX_NODE_INSTANCES: usize = 100_000;
/// Most (node instance, primitive) pairs. Each costs a few small allocations, so this keeps
/// a file of many tiny primitives from taking minutes within the vertex budget.
pub const MAX_PRIMITIVE_INSTANCES: usize = 1 << 18;
/// Largest file read from disk: the glTF/GLB itself and each external buffer or image
/// (`load_gltf` only; data in memory is bounded by its own size).
pub const MAX_BUFFER_BYTES: u64 = 2 << 30;

/// A GLB header whose total length is shorter than the header itself makes the crate
/// subtract with overflow.
pub(super) fn check_glb_header(bytes: &[u8]) -> Result<(), String> {
    if bytes.starts_with(b"glTF") && bytes.len() >= 12 {
        let length = u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]);
        if length < 12 {
            return Err(format!(
                "GLB header gives a total length of {length} bytes, less than the 12-byte header"
            ));
        }
    }
    Ok(())
}

/// What must hold before the crate's own validator runs (it indexes with these).
pub(super) fn check_before_validation(root: &gltf::json::Root) -> Result<(), String> {
    use gltf::json::{mesh::Semantic, validation::Checked};
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            if let Some(i) = prim.attributes.get(&Checked::Valid(Semantic::Positions))
                && i.value() >= root.accessors.len()
            {
                return Err(format!(
                    "mesh {m} primitive {p}: POSITION accessor {} does not exist ({} accessors)",
                    i.value(),
                    root.accessors.len()
                ));
            }
        }
    }
    Ok(())
}

/// Percent-decodes like the crate's `urlencoding::decode`; `None` where it would panic.
fn percent_decode(s: &str) -> Option<String> {
    let b = s.as_bytes();
    let hex = |c: u8| (c as char).to_digit(16).map(|d| d as u8);
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        match (
            b[i],
            b.get(i + 1).copied().and_then(hex),
            b.get(i + 2).copied().and_then(hex),
        ) {
            (b'%', Some(hi), Some(lo)) => {
                out.push(hi << 4 | lo);
                i += 3;
            }
            (c, _, _) => {
                out.push(c);
                i += 1;
            }
        }
    }
    String::from_utf8(out).ok()
}

/// Checks a buffer or image URI before the crate reads it. Relative and `file:` URIs name
/// files that must be regular (never `/dev/zero` or a FIFO, which would hang or exhaust
/// memory) and at most [`MAX_BUFFER_BYTES`]. `base` is `None` for in-memory files, which
/// may only embed data URIs.
pub(super) fn check_uri(uri: &str, base: Option<&Path>, what: &str) -> Result<(), String> {
    let path: PathBuf = if uri.contains(':') {
        if uri.starts_with("data:") {
            return Ok(());
        }
        match uri
            .strip_prefix("file://")
            .or_else(|| uri.strip_prefix("file:"))
        {
            Some(p) => PathBuf::from(p),
            // The crate reports unsupported schemes itself.
            None => return Ok(()),
        }
    } else {
        let decoded = percent_decode(uri)
            .ok_or_else(|| format!("{what}: URI is not valid percent-encoded UTF-8"))?;
        match base {
            Some(base) => base.join(decoded),
            None => PathBuf::from(decoded),
        }
    };
    if base.is_none() {
        return Err(format!(
            "{what}: refers to an external file, which an in-memory glTF cannot"
        ));
    }
    crate::input::check_regular(&path, MAX_BUFFER_BYTES)
        .map_err(|e| format!("{what}: cannot read {}: {e}", path.display()))?;
    Ok(())
}

/// The bytes of a buffer view, or why they are not all there.
pub(super) fn view_bytes<'b>(
    view: &gltf::buffer::View,
    buffers: &'b [gltf::buffer::Data],
) -> Result<&'b [u8], String> {
    let b = view.buffer().index();
    let data = buffers.get(b).map_or(&[][..], |d| &d.0[..]);
    view.offset()
        .checked_add(view.length())
        .and_then(|end| data.get(view.offset()..end))
        .ok_or_else(|| {
            format!(
                "buffer view {} (bytes {}, length {}) does not fit in buffer {b} ({} bytes)",
                view.index(),
                view.offset(),
                view.length(),
                data.len()
            )
        })
}

/// Checks that `count` elements of `size` bytes, `stride` apart, starting at `offset`, lie
/// inside `view`, and returns that byte range of it.
fn elements<'b>(
    view: &gltf::buffer::View,
    buffers: &'b [gltf::buffer::Data],
    offset: usize,
    size: usize,
    count: usize,
    what: &str,
) -> Result<(&'b [u8], usize), String> {
    let bytes = view_bytes(view, buffers).map_err(|e| format!("{what}: {e}"))?;
    let stride = view.stride().unwrap_or(size);
    if stride < size {
        return Err(format!(
            "{what}: byteStride {stride} of buffer view {} is less than the element size {size}",
            view.index()
        ));
    }
    let end = stride
        .checked_mul(count.saturating_sub(1))
        .and_then(|n| n.checked_add(size))
        .and_then(|n| n.checked_add(offset));
    match end.and_then(|end| bytes.get(offset..end)) {
        Some(range) => Ok((range, stride)),
        None => Err(format!(
            "{what}: {count} elements of {size} bytes from byte {offset} run past the end of \
             buffer view {} ({} bytes)",
            view.index(),
            bytes.len()
        )),
    }
}

/// Checks everything the crate's reader assumes about `acc` - element type, `count >= 1`,
/// every byte range (sparse ones too) inside its buffer, sparse indices increasing and
/// below `count` - without allocating. Returns `count`; `what` names the accessor's use
/// (e.g. "mesh 0 primitive 1: POSITION") for the message.
pub(super) fn check_accessor(
    acc: &gltf::Accessor,
    buffers: &[gltf::buffer::Data],
    dims: Dimensions,
    types: &[DataType],
    what: &str,
) -> Result<usize, String> {
    let what = format!("{what} accessor {}", acc.index());
    if acc.dimensions() != dims || !types.contains(&acc.data_type()) {
        return Err(format!(
            "{what} is {:?} of {:?}; expected {dims:?} of {}",
            acc.dimensions(),
            acc.data_type(),
            types
                .iter()
                .map(|t| format!("{t:?}"))
                .collect::<Vec<_>>()
                .join(" or ")
        ));
    }
    let count = acc.count();
    if count == 0 {
        return Err(format!("{what} has count 0"));
    }
    let size = acc.size();
    if let Some(view) = acc.view() {
        elements(&view, buffers, acc.offset(), size, count, &what)?;
    }
    if let Some(sparse) = acc.sparse() {
        let n = sparse.count();
        if n == 0 || n > count {
            return Err(format!(
                "{what}: sparse count {n} is not in 1..={count} (the accessor count)"
            ));
        }
        let idx = sparse.indices();
        let isize = idx.index_type().size();
        let what_idx = format!("{what}: sparse indices");
        let (bytes, stride) = elements(&idx.view(), buffers, idx.offset(), isize, n, &what_idx)?;
        let mut prev: Option<u64> = None;
        for k in 0..n {
            let e = &bytes[k * stride..k * stride + isize];
            let i = e.iter().rev().fold(0u64, |a, &b| a << 8 | b as u64);
            if i >= count as u64 || prev.is_some_and(|p| i <= p) {
                return Err(format!(
                    "{what}: sparse index {i} (entry {k}) is out of order or not below the \
                     count {count}"
                ));
            }
            prev = Some(i);
        }
        let vals = sparse.values();
        elements(
            &vals.view(),
            buffers,
            vals.offset(),
            size,
            n,
            &format!("{what}: sparse values"),
        )?;
    }
    Ok(count)
}

/// Fails if the node hierarchy has a cycle, naming a node on it. Iterative depth-first
/// search; the "on the current path" marks are the per-path visited set.
pub(super) fn check_node_cycles(doc: &gltf::Document) -> Result<(), String> {
    const NEW: u8 = 0;
    const ON_PATH: u8 = 1;
    const DONE: u8 = 2;
    let nodes = &doc.as_json().nodes;
    let mut state = vec![NEW; nodes.len()];
    let children = |n: usize| nodes[n].children.as_deref().unwrap_or(&[]);
    for start in 0..nodes.len() {
        if state[start] != NEW {
            continue;
        }
        state[start] = ON_PATH;
        let mut stack = vec![(start, 0usize)];
        while let Some((node, next)) = stack.last_mut() {
            let node = *node;
            match children(node).get(*next) {
                Some(child) => {
                    *next += 1;
                    let c = child.value();
                    match state[c] {
                        ON_PATH => {
                            return Err(format!(
                                "node {c} is its own ancestor (child of node {node}): the node \
                                 hierarchy has a cycle"
                            ));
                        }
                        NEW => {
                            state[c] = ON_PATH;
                            stack.push((c, 0));
                        }
                        _ => {}
                    }
                }
                None => {
                    state[node] = DONE;
                    stack.pop();
                }
            }
        }
    }
    Ok(())
}

/// One occurrence of a node in the scene, with its world transform.
#[derive(Clone, Copy, Debug)]
pub(super) struct Instance {
    pub node: usize,
    pub world: Mat4,
}

/// Expands the node hierarchy below `roots` into node instances, iteratively. glTF
/// requires the hierarchy to be a forest, but a node reached through several parents
/// (a DAG, i.e. instancing) is drawn once per path; [`MAX_NODE_INSTANCES`] bounds the
/// total and [`MAX_NODE_DEPTH`] the depth, so even a cycle that slipped past
/// [`check_node_cycles`] ends in an error. Instances come sorted by node index (stable),
/// the order in which earlier versions appended meshes.
pub(super) fn expand_instances(
    doc: &gltf::Document,
    roots: &[usize],
) -> Result<Vec<Instance>, String> {
    let nodes = &doc.as_json().nodes;
    let local: Vec<Mat4> = doc
        .nodes()
        .map(|n| Mat4::from_cols_array_2d(&n.transform().matrix()))
        .collect();
    let mut out = Vec::new();
    let mut stack: Vec<(usize, Mat4, usize)> = roots
        .iter()
        .rev()
        .map(|&r| (r, Mat4::IDENTITY, 1))
        .collect();
    while let Some((node, parent, depth)) = stack.pop() {
        if depth > MAX_NODE_DEPTH {
            return Err(format!(
                "node {node} is more than {MAX_NODE_DEPTH} levels deep in the node hierarchy"
            ));
        }
        let world = parent * local[node];
        out.push(Instance { node, world });
        let children = nodes[node].children.as_deref().unwrap_or(&[]);
        // Every stack entry becomes an instance, so checking here also bounds the stack.
        if out.len() + stack.len() + children.len() > MAX_NODE_INSTANCES {
            return Err(format!(
                "the node graph expands to more than {MAX_NODE_INSTANCES} node instances \
                 (node {node} and its ancestors are reached through many paths)"
            ));
        }
        stack.extend(children.iter().rev().map(|c| (c.value(), world, depth + 1)));
    }
    out.sort_by_key(|i| i.node);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percent_decode_matches_urlencoding_and_rejects_bad_utf8() {
        assert_eq!(percent_decode("a%20b.bin").as_deref(), Some("a b.bin"));
        assert_eq!(percent_decode("100%").as_deref(), Some("100%"));
        assert_eq!(percent_decode("%zz%4").as_deref(), Some("%zz%4"));
        assert_eq!(percent_decode("%C3%A9").as_deref(), Some("é"));
        assert_eq!(percent_decode("%FF"), None);
        assert_eq!(percent_decode("%C3"), None);
    }

    #[test]
    fn external_uris_must_be_regular_files() {
        assert!(check_uri("data:application/octet-stream;base64,AAAA", None, "b").is_ok());
        let e = check_uri("x.bin", None, "buffer 0").unwrap_err();
        assert!(e.contains("buffer 0") && e.contains("external"), "{e}");
        let e = check_uri("%FF.bin", Some(Path::new("/tmp")), "buffer 0").unwrap_err();
        assert!(e.contains("percent-encoded"), "{e}");
        if Path::new("/dev/zero").exists() {
            let e = check_uri("file:///dev/zero", Some(Path::new("/")), "buffer 1").unwrap_err();
            assert!(e.contains("not a regular file"), "{e}");
        }
        let e = check_uri("missing.bin", Some(Path::new("/nonexistent")), "buffer 2").unwrap_err();
        assert!(e.contains("cannot read"), "{e}");
    }

    #[test]
    fn glb_header_shorter_than_itself_is_rejected() {
        let mut h = b"glTF".to_vec();
        h.extend_from_slice(&2u32.to_le_bytes());
        h.extend_from_slice(&4u32.to_le_bytes());
        assert!(check_glb_header(&h).unwrap_err().contains("12-byte header"));
        h[8] = 12;
        assert!(check_glb_header(&h).is_ok());
        assert!(check_glb_header(b"{}").is_ok());
    }
}
