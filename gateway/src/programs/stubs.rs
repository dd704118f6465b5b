//! Program skeletons (`petrel stubs`).
