// Shared by maps_priority and maps_flatten (prepended by the host after dispatch.wgsl): the
// batch of ordered 1-rings (`RingHeader` in gpu/src/maps/mod.rs) and the kernels' uniform.
const KIND_DISK: u32 = 0u;
const KIND_HALF_DISK: u32 = 1u;
const KIND_FEATURE_LINE: u32 = 2u;

struct RingHeader {
    centre: u32,
    first: u32,
    count: u32,
    kind: u32,
    s: u32,
    t: u32,
    _pad0: u32,
    _pad1: u32,
}

struct CountParams {
    count: u32,
    limit: u32,
    _pad0: u32,
    _pad1: u32,
}

// Number of sectors (j_m, j_{m+1}) of a ring: K when closed, K − 1 for a half disk.
fn sector_count(h: RingHeader) -> u32 {
    if (h.kind == KIND_HALF_DISK) {
        return h.count - 1u;
    }
    return h.count;
}
