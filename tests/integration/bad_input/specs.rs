//! Bad input: specs (see the parent module).
