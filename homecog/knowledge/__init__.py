"""The knowledge stage: samples, the IHDR tree, its store, cognition and corrections."""
