//! Ingest: load a batch of scenes, compile them, write the manifest.
