//! A .gltf with its external files: the input is the JSON, a NUL byte, then the bytes every
//! external `uri` resolves to (a buffer or an image). Seeds: each .gltf of tests/assets with its
//! one .bin.
#![no_main]

use kloub_core::{Resolver, import};
use libfuzzer_sys::fuzz_target;

mod common;

/// Every uri is `self.0`.
struct Same<'a>(&'a [u8]);

impl Resolver for Same<'_> {
    fn resolve(&self, _uri: &str) -> Result<Vec<u8>, String> {
        Ok(self.0.to_vec())
    }
}

fuzz_target!(|data: &[u8]| {
    let (json, file) = match data.iter().position(|&b| b == 0) {
        Some(at) => (&data[..at], &data[at + 1..]),
        None => (data, &[][..]),
    };
    let _ = import(json, &Same(file), &common::options());
});
