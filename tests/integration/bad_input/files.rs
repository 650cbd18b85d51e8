//! Bad input: files (see the parent module).
