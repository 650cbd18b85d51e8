//! TFRecord framing. Being written.
