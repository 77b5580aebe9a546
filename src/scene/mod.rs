//! Scene renderer (placeholder; being written).
