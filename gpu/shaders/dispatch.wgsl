// Shared by every compute kernel of reparam-gpu (prepended by the host: WGSL has no includes).
//
// Kernels run one invocation per item on a 2D grid of workgroups of WORKGROUP_SIZE (the host's
// `workgroup_grid` splits into rows when the count exceeds max_compute_workgroups_per_dimension);
// each invocation rebuilds its item index and returns when it is >= the item count.

const WORKGROUP_SIZE: u32 = 64u;

// Linear item index of an invocation: gid.x + gid.y · (workgroups per row · WORKGROUP_SIZE).
fn linear_index(gid: vec3<u32>, workgroups: vec3<u32>) -> u32 {
    return gid.x + gid.y * workgroups.x * WORKGROUP_SIZE;
}
