//! Camera paths (placeholder; being written).
