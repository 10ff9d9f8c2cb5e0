// CSR graph bindings (int32 on the device): row i lists the sources j of the
// edges e = (j -> i) in [indptr[i], indptr[i+1]); the transpose lists, for a
// source j, the destinations out_dst[t] and edge ids out_edge[t] for t in
// [out_ptr[j], out_ptr[j+1]). Backward passes gather over the transpose: no atomics.
