// gridwarp_aa_residuals: one invocation per sample, its two residuals r^s, r^t alone, for the
// conformance vectors (`reparam vectors gridwarp`, kernel `gridwarp_aa.residuals`). Appended by
// the host after dispatch.wgsl and gridwarp_aa.wgsl, whose `cell_lines` and `sample_residuals`
// it calls as `gridwarp_aa_cell` does for one sample, so its residuals are those that kernel
// sums. A sample of weight σ = 0 has none: it writes (0, 0).
//
// Its output takes binding 5, `cells`' slot: the two entry points never run in one pipeline.

@group(0) @binding(5) var<storage, read_write> residuals: array<vec2<f32>>;

@compute @workgroup_size(WORKGROUP_SIZE)
fn gridwarp_aa_residuals(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) workgroups: vec3<u32>) {
    // The residuals need no unknown map; touching it keeps this entry point's bindings those
    // of `gridwarp_aa_cell` (the host binds the same six buffers, in the same slots).
    _ = unknown_index[0];
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
    let r = sample_residuals(cell_lines(cell_index / params.rows, cell_index % params.rows), sample);
    residuals[index] = vec2<f32>(r.r_s, r.r_t);
}
