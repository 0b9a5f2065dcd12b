//! What the viewers of a page share: one download and one decoded asset per model URL.
//!
//! Many `<kloub-viewer>`s on a page often show the same model (a gallery, a product page with
//! several angles). The first viewer to ask for a URL fetches it; the others that ask while the
//! download runs wait for the same one ([`join_fetch`], [`finish_fetch`]). The files come to
//! every waiter as one reference-counted list ([`SharedFiles`]); whichever viewer handles its
//! delivery first imports them and remembers the decoded asset ([`remember`]), and every other
//! viewer takes that ([`cached`]) instead of importing again. Only weak references are kept here:
//! the asset lives as long as some viewer shows it, and a later request after that fetches anew.
//! The GPU side of the same sharing is in [`crate::render`] (one upload per asset and device).
//!
//! Platform-free (the fetch itself is [`crate::load::fetch_into`]), so it is tested natively.

use std::cell::RefCell;
use std::collections::HashMap;
use std::rc::Rc;
use std::sync::{Arc, Weak};

use kloub_core::Warning;
use kloub_core::asset::Asset;

use crate::load::{Inbox, LoadedModel, SourceFile};

/// The files of one download, handed to every viewer that waited for it.
pub type SharedFiles = Rc<Vec<SourceFile>>;

/// A decoded model, remembered by URL while some viewer shows it.
struct Decoded {
    url: String,
    asset: Weak<Asset>,
    name: String,
    warnings: Vec<Warning>,
}

/// Counts per URL, for tests and the memory benchmark: downloads started and imports done.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counts {
    /// Downloads started.
    pub fetches: u32,
    /// Imports (decodes) done.
    pub decodes: u32,
}

#[derive(Default)]
struct Registry {
    decoded: Vec<Decoded>,
    /// Downloads under way: who waits for each URL (their inbox and waker).
    fetching: HashMap<String, Vec<(Inbox, crate::control::Wake)>>,
    counts: HashMap<String, Counts>,
}

thread_local! {
    static REGISTRY: RefCell<Registry> = RefCell::new(Registry::default());
}

/// The model decoded from `url` if a viewer of the page still shows it.
pub fn cached(url: &str) -> Option<LoadedModel> {
    REGISTRY.with(|r| {
        let mut r = r.borrow_mut();
        r.decoded.retain(|d| d.asset.strong_count() > 0);
        let d = r.decoded.iter().find(|d| d.url == url)?;
        Some(LoadedModel {
            name: d.name.clone(),
            asset: d.asset.upgrade()?,
            warnings: d.warnings.clone(),
            sidecar: None,
        })
    })
}

/// Remembers `model`, imported from `url`, for the page's other viewers; counts the decode.
pub fn remember(url: &str, model: &LoadedModel) {
    REGISTRY.with(|r| {
        let mut r = r.borrow_mut();
        r.counts.entry(url.to_owned()).or_default().decodes += 1;
        r.decoded.retain(|d| d.asset.strong_count() > 0 && d.url != url);
        r.decoded.push(Decoded {
            url: url.to_owned(),
            asset: Arc::downgrade(&model.asset),
            name: model.name.clone(),
            warnings: model.warnings.clone(),
        });
    });
}

/// Asks for `url` for the viewer with `inbox`: `true` when this call should start the download
/// (nobody is fetching it yet; it is counted), `false` when it joined one under way (its
/// delivery comes with [`finish_fetch`]).
pub fn join_fetch(url: &str, inbox: &Inbox, ctx: &crate::control::Wake) -> bool {
    REGISTRY.with(|r| {
        let mut r = r.borrow_mut();
        let first = !r.fetching.contains_key(url);
        r.fetching.entry(url.to_owned()).or_default().push((inbox.clone(), ctx.clone()));
        if first {
            r.counts.entry(url.to_owned()).or_default().fetches += 1;
        }
        first
    })
}

/// The download of `url` ended: everyone who waited for it (their inbox and context).
pub fn finish_fetch(url: &str) -> Vec<(Inbox, crate::control::Wake)> {
    REGISTRY.with(|r| r.borrow_mut().fetching.remove(url).unwrap_or_default())
}

/// Downloads and decodes per URL so far.
pub fn counts() -> Vec<(String, Counts)> {
    REGISTRY.with(|r| {
        let mut all: Vec<(String, Counts)> = r.borrow().counts.iter().map(|(u, c)| (u.clone(), *c)).collect();
        all.sort_by(|a, b| a.0.cmp(&b.0));
        all
    })
}

/// How many decoded models are remembered and still shown by some viewer.
pub fn live_models() -> usize {
    REGISTRY.with(|r| r.borrow().decoded.iter().filter(|d| d.asset.strong_count() > 0).count())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model(name: &str) -> LoadedModel {
        LoadedModel { name: name.into(), asset: Arc::new(Asset::default()), warnings: Vec::new(), sidecar: None }
    }

    #[test]
    fn a_decoded_model_is_shared_while_a_viewer_shows_it_and_forgotten_after() {
        let shown = model("Fox.glb");
        remember("/a/Fox.glb", &shown);
        let again = cached("/a/Fox.glb").expect("still shown");
        assert!(Arc::ptr_eq(&again.asset, &shown.asset), "the same asset, not a copy");
        assert_eq!(again.name, "Fox.glb");
        assert!(cached("/a/Other.glb").is_none());
        drop((shown, again));
        assert!(cached("/a/Fox.glb").is_none(), "no viewer shows it: forgotten");
        let counts = counts().into_iter().find(|(u, _)| u == "/a/Fox.glb").map(|(_, c)| c);
        assert_eq!(counts, Some(Counts { fetches: 0, decodes: 1 }));
    }

    #[test]
    fn viewers_asking_for_a_url_under_way_join_the_one_download() {
        let ctx = crate::control::Wake::new(|| ());
        let (a, b, c) = (Inbox::default(), Inbox::default(), Inbox::default());
        assert!(join_fetch("/b/Knight.glb", &a, &ctx), "the first starts it");
        assert!(!join_fetch("/b/Knight.glb", &b, &ctx), "the second waits");
        assert!(!join_fetch("/b/Knight.glb", &c, &ctx));
        assert_eq!(finish_fetch("/b/Knight.glb").len(), 3, "all three get the files");
        assert!(finish_fetch("/b/Knight.glb").is_empty());
        assert!(join_fetch("/b/Knight.glb", &a, &ctx), "a later request downloads again");
        let _ = finish_fetch("/b/Knight.glb");
        let counts = counts().into_iter().find(|(u, _)| u == "/b/Knight.glb").map(|(_, c)| c);
        assert_eq!(counts, Some(Counts { fetches: 2, decodes: 0 }));
    }
}
