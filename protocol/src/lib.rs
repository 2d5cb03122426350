#![no_std]
//! Placeholder: filled in by the protocol work.
