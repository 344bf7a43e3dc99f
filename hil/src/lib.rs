//! Nothing: the on-target tests are `tests/board.rs` (embedded-test's harness).
#![no_std]
