//! Bad input: planners (see the parent module).
