//! Bad input: hangs (see the parent module).
