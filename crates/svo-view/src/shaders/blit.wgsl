// Shows the tracer's frame in the window: a full-screen triangle whose fragments read the
// pixel buffer that trace.wgsl wrote (the same buffer the headless path reads back), scaled
// to the window when the frame is rendered at a lower resolution, and sRGB-encoded unless the
// surface format does that itself.

override SRGB_ENCODE: bool = true;

// As trace.wgsl's Pixel (the layout test checks both against gpu_types::GpuPixel).
struct Pixel {
    colour: vec3<f32>,
    depth: f32,
    normal: vec3<f32>,
    leaf: u32,
    primary_steps: u32,
    steps: u32,
    rays: u32,
    capped: u32,
}

struct BlitParams {
    frame: vec2<u32>,          // the frame's size
    dest: vec2<u32>,           // the size drawn to (the window)
}

@group(0) @binding(0) var<storage, read> pixels: array<Pixel>;
@group(0) @binding(1) var<uniform> bp: BlitParams;

@vertex
fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let x = f32(i32(i & 1u) * 4 - 1);
    let y = f32(i32(i >> 1u) * 4 - 1);
    return vec4<f32>(x, y, 0.0, 1.0);
}

fn encode(c: f32) -> f32 {
    let v = clamp(c, 0.0, 1.0);
    if v <= 0.0031308 {
        return v * 12.92;
    }
    return 1.055 * pow(v, 1.0 / 2.4) - 0.055;
}

@fragment
fn fs(@builtin(position) pos: vec4<f32>) -> @location(0) vec4<f32> {
    let fx = min(u32(pos.x * f32(bp.frame.x) / f32(max(bp.dest.x, 1u))), bp.frame.x - 1u);
    let fy = min(u32(pos.y * f32(bp.frame.y) / f32(max(bp.dest.y, 1u))), bp.frame.y - 1u);
    let c = pixels[fy * bp.frame.x + fx].colour;
    if SRGB_ENCODE {
        return vec4<f32>(encode(c.x), encode(c.y), encode(c.z), 1.0);
    }
    return vec4<f32>(clamp(c, vec3<f32>(0.0), vec3<f32>(1.0)), 1.0);
}
