// gridwarp_naa_residuals: one invocation per sample, its two residuals r^s, r^t alone, for the
// conformance vectors (`gridwarp_naa.residuals`). Appended by the host after dispatch.wgsl,
// gridwarp_field.wgsl and gridwarp_naa.wgsl, whose `rest_cell`, `corners` and
// `sample_residuals` it calls as `gridwarp_naa_cell` does for one sample, so its residuals are
// those that kernel sums. A sample of weight σ = 0 has none: it writes (0, 0).
//
// Its output takes binding 8, `cells`' slot: the two entry points never run in one pipeline.

@group(0) @binding(8) var<storage, read_write> residuals: array<vec2<f32>>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn gridwarp_naa_residuals(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) workgroups: vec3<u32>) {
    // The residuals need no unknown map; touching it keeps this entry point's bindings those
    // of `gridwarp_naa_cell` (the host binds the same nine buffers, in the same slots).
    _ = vertex_index[0];
    let index = linear_index(gid, workgroups);
    if index >= params.cells * params.per_cell {
        return;
    }
    let sample = samples[index];
    if sample.sigma == 0.0 {
        residuals[index] = vec2<f32>(0.0, 0.0);
        return;
    }
    // Sample n of cell (i, j) = cell column i, row j, at i·rows + j.
    let cell_index = index / params.per_cell;
    let i = cell_index / params.rows;
    let j = cell_index % params.rows;
    let r = sample_residuals(rest_cell(i, j), corners(i, j), sample);
    residuals[index] = vec2<f32>(r.r_s, r.r_t);
}
