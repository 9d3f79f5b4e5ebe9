//! The page's files, embedded in the binary: the bundle that `web/build.sh` builds from `web/`
//! (three.js and the page's modules, bundled by vite) into `crates/squish-cli/web-bundle/`, which
//! is committed so that `cargo build` needs no Node. `web-bundle/SOURCES` holds a hash of the
//! sources it was built from; a test fails when the sources changed since (rebuild with
//! `web/build.sh`).
//!
//! Only these files are served: a request names one of them or gets 404, so no request reads
//! the disk.

use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};

/// (path as requested, content type, bytes).
const FILES: [(&str, &str, &[u8]); 3] = [
    ("index.html", "text/html; charset=utf-8", include_bytes!("../../web-bundle/index.html")),
    ("assets/app.js", "text/javascript; charset=utf-8", include_bytes!("../../web-bundle/assets/app.js")),
    ("assets/style.css", "text/css; charset=utf-8", include_bytes!("../../web-bundle/assets/style.css")),
];

/// The embedded file `path`, or 404.
pub fn response(path: &str) -> Response {
    match FILES.iter().find(|(name, _, _)| *name == path) {
        Some((_, content_type, bytes)) => {
            ([(header::CONTENT_TYPE, *content_type), (header::CACHE_CONTROL, "no-cache")], *bytes).into_response()
        }
        None => (StatusCode::NOT_FOUND, "not found").into_response(),
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // tests may unwrap: a panic is the failure report
mod tests {
    use std::path::Path;

    use super::*;

    /// The hash `web/build.sh` records (`web/tools/sources-hash.mjs`): FNV-1a 64 over every source
    /// file, in sorted path order, of `path NUL bytes NUL`.
    fn sources_hash(files: &[(String, Vec<u8>)]) -> u64 {
        const OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
        const PRIME: u64 = 0x0000_0100_0000_01b3;
        let mut hash = OFFSET;
        let mut feed = |bytes: &[u8]| {
            for &b in bytes {
                hash ^= u64::from(b);
                hash = hash.wrapping_mul(PRIME);
            }
        };
        let mut sorted: Vec<&(String, Vec<u8>)> = files.iter().collect();
        sorted.sort_by(|a, b| a.0.cmp(&b.0));
        for (path, bytes) in sorted {
            feed(path.as_bytes());
            feed(&[0]);
            feed(bytes);
            feed(&[0]);
        }
        hash
    }

    /// The page's sources, as `web/tools/sources-hash.mjs` lists them (paths relative to `web/`).
    fn web_sources(web: &Path) -> Vec<(String, Vec<u8>)> {
        let mut files = Vec::new();
        for top in ["index.html", "vite.config.js", "package.json", "package-lock.json"] {
            files.push((top.to_string(), std::fs::read(web.join(top)).unwrap()));
        }
        let mut stack = vec![web.join("src")];
        while let Some(dir) = stack.pop() {
            for entry in std::fs::read_dir(&dir).unwrap() {
                let path = entry.unwrap().path();
                if path.is_dir() {
                    stack.push(path);
                } else {
                    let relative = path.strip_prefix(web).unwrap().to_string_lossy().replace('\\', "/");
                    files.push((relative, std::fs::read(&path).unwrap()));
                }
            }
        }
        files
    }

    #[test]
    fn the_committed_bundle_is_built_from_the_current_sources() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let recorded = std::fs::read_to_string(root.join("web-bundle/SOURCES")).unwrap();
        let current = format!("{:016x}", sources_hash(&web_sources(&root.join("../../web"))));
        assert_eq!(
            recorded.trim(),
            current,
            "crates/squish-cli/web-bundle is stale: web/ changed since it was built; run web/build.sh and commit the bundle"
        );
    }

    #[test]
    fn only_embedded_files_are_served() {
        assert_eq!(response("index.html").status(), StatusCode::OK);
        for path in ["../Cargo.toml", "/etc/passwd", "assets/../../Cargo.toml", "assets/missing.js", ""] {
            assert_eq!(response(path).status(), StatusCode::NOT_FOUND, "{path}");
        }
    }
}
