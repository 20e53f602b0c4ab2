//! Train/val/test splits: filter expressions, official lists, seeded ratio splits.
