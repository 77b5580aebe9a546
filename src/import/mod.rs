//! Importers of real data (placeholder; being written).
