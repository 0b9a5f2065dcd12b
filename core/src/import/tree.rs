//! The glTF JSON document as a tree that borrows its strings from the file's bytes: the
//! `kloub-json` crate (core/json), of its own so that the web bundle builds the parse for
//! speed while the importer is built for size.

#[cfg(test)]
pub(crate) use kloub_json::parse;
pub(crate) use kloub_json::{Arena, Map, Value, parse_counted};
