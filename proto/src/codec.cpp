// Filled by the wire-protocol work: see codec.hpp.
