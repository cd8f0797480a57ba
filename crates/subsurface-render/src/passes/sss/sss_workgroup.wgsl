
// Separable SSS as compute passes over lines (rows for the horizontal pass, columns for the
// vertical one): on a GPU a workgroup loads its stretch of the line, plus an apron on each
// side, once into workgroup memory, and every tap inside it reads from there instead of the
// texture (on a CPU adapter every tap reads the texture: LINE_SHARED). Taps
// past the apron (wide kernels seen up close) fall back to the texture. The result is the
// fragment passes' to the bit: the same taps, corrections and bilinear weights.
//
// The horizontal pass packs its texels itself as it loads them (FROM_INPUTS): a separate pack
// step would be one more full-screen pass, and on GPUs whose raster units are few for their
// memory (the H200) a full-screen fragment pass costs several times what a compute pass over
// the same pixels does.
override FROM_INPUTS: bool = false;

// Whether the workgroup loads its stretch into workgroup memory at all. CPU adapters run the
// passes without it, after a pack step, each tap reading the packed texture: llvmpipe gathers
// workgroup memory lane by lane, word by word, and its texel fetch was the faster of the two
// (workgroup::LineFetch::Texture).
override LINE_SHARED: bool = true;

const LINE_TILE: u32 = 128u;
const LINE_APRON: i32 = 64;
const LINE_SPAN: u32 = 256u; // LINE_TILE + 2 LINE_APRON

var<workgroup> line_texels: array<vec4<u32>, 256>;

// The horizontal pass writes the packed layout for the vertical one, which writes the colour.
@group(0) @binding(7) var out_packed: texture_storage_2d<rgba32uint, write>;
@group(0) @binding(8) var out_color: texture_storage_2d<rgba16float, write>;

struct Line {
    origin: i32, // first texel of this workgroup's stretch, along the line
    across: u32, // the row (horizontal pass) or column (vertical pass)
    last: i32,   // last texel of the line
};

fn line_texel(along: i32, line: Line) -> vec2<i32> {
    if (u.direction.x > 0.5) {
        return vec2<i32>(along, i32(line.across));
    }
    return vec2<i32>(i32(line.across), along);
}

// The packed texel (sss_packed.wgsl) at `texel`: packed here from the three inputs, exactly as
// fs_pack packs it, or read from the previous pass's packed output.
fn input_texel(texel: vec2<i32>) -> vec4<u32> {
    if (FROM_INPUTS) {
        let c = input_centre(texel);
        return pack(c.color, c);
    }
    return textureLoad(packed_tex, texel, 0);
}

fn line_fetch(along: i32, line: Line) -> vec4<u32> {
    if (LINE_SHARED) {
        let k = along - (line.origin - LINE_APRON);
        if (k >= 0 && k < i32(LINE_SPAN)) {
            return line_texels[k];
        }
    }
    return input_texel(line_texel(along, line));
}

// `tap` (sss.wgsl) along the line: q is the tap's position along it, in pixels.
fn line_tap(q: f32, line: Line, c: Centre) -> vec3<f32> {
    let t = q - 0.5;
    let i0 = floor(t);
    let f = t - i0;
    var v = corrected_texel(line_fetch(clamp(i32(i0), 0, line.last), line), c);
    if (f > 0.0) {
        let b = corrected_texel(line_fetch(clamp(i32(i0) + 1, 0, line.last), line), c);
        v = mix(v, b, f);
    }
    return v;
}

// Loads the workgroup's stretch and its apron (clamped at the line's ends, as `tap` clamps)
// into workgroup memory, where the line is shared.
fn load_line(group: vec3<u32>, index: u32) -> Line {
    var size = extent();
    if (FROM_INPUTS) {
        // packed_tex is a stand-in here.
        size = vec2<i32>(textureDimensions(color_tex));
    }
    var line: Line;
    line.last = select(size.y, size.x, u.direction.x > 0.5) - 1;
    if (u.direction.x > 0.5) {
        line.across = u.region.y + group.y;
        line.origin = i32(u.region.x + group.x * LINE_TILE);
    } else {
        line.across = u.region.x + group.y;
        line.origin = i32(u.region.y + group.x * LINE_TILE);
    }
    if (LINE_SHARED) {
        for (var k = index; k < LINE_SPAN; k += LINE_TILE) {
            let along = clamp(line.origin - LINE_APRON + i32(k), 0, line.last);
            line_texels[k] = input_texel(line_texel(along, line));
        }
        workgroupBarrier();
    }
    return line;
}

fn store_line(texel: vec2<i32>, sum: vec3<f32>, c: Centre) {
    if (u.seed == 0u) {
        textureStore(out_packed, texel, pack(sum, c));
    } else if (c.strength > 0.0) {
        // The pass works in place on the diffuse target: a pixel that is not skin already holds
        // its colour there, so only skin is written back.
        textureStore(out_color, texel, vec4<f32>(sum, 1.0));
    }
}

// One 1-D pass of the kernel over this workgroup's stretch; `jittered`: the few-sample mode's
// moved taps (separable_jitter in sss.wgsl).
fn separable_line(group: vec3<u32>, index: u32, jittered: bool) {
    let line = load_line(group, index);
    let along = line.origin + i32(index);
    // The last stretch may run past the region: its pixels are not this pass's to write.
    let end = i32(select(u.region.w, u.region.z, u.direction.x > 0.5));
    if (along > line.last || along >= end) {
        return;
    }
    let texel = line_texel(along, line);
    var t: vec4<u32>;
    if (LINE_SHARED) {
        t = line_texels[u32(LINE_APRON) + index];
    } else {
        t = input_texel(texel);
    }
    let c = centre_of(t);
    var sum = c.color;
    if (c.strength > 0.0) {
        let q = f32(along) + 0.5;
        let seed = jitter_seed(vec2<u32>(texel));
        sum = table[c.base].rgb * c.color;
        for (var i = 1u; i < u.taps; i++) {
            let k = table[c.base + i];
            var o = k.w;
            if (jittered) {
                o = jittered_offset(seed, i, k.w, c);
            }
            sum += k.rgb * line_tap(q + o * c.px_per_mm, line, c);
        }
    }
    store_line(texel, sum, c);
}

@compute @workgroup_size(128)
fn cs_separable(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) index: u32) {
    separable_line(group, index, false);
}

@compute @workgroup_size(128)
fn cs_separable_jitter(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) index: u32) {
    separable_line(group, index, true);
}
