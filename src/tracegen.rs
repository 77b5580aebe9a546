//! Trace generation (placeholder; being written).
