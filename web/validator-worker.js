// The Khronos glTF-Validator (npm gltf-validator, compiled from Dart to JS) in a worker of its own, started by
// <kloub-viewer>'s validate() the first time it is called: the validator is fetched only then, and a large file is
// validated off the page's main thread. The element creates this worker from a blob (so that it works when the
// element is served from another origin than the page) and sends the validator's absolute URL first.
//
// Messages in:  { validator: URL }                       once, first
//               { id, name, bytes: ArrayBuffer | Blob, files: { [path]: Blob } | null, base: URL | null }
//               (dropped files come as their File objects, which the page shares without a copy: only the ones the
//               model refers to are read, here)
// Messages out: { id, report }  (the validator's report object)  or  { id, error: string }
//               { loadError: string }  (the validator script failed; nothing more comes from this worker)
let validator = null;
const queue = [];

function validatorFrom(url) {
  // The dart2js build publishes its API on a global `exports` when one exists.
  self.exports = {};
  importScripts(url);
  if (typeof self.exports.validateBytes !== 'function') throw new Error('the validator script has no validateBytes');
  return self.exports;
}

/** The folder part of a relative path, with a trailing slash ('' at the top). */
const folderOf = (path) => path.slice(0, path.lastIndexOf('/') + 1);

/** `path` with `.` and `..` segments applied and `\` as `/`. */
function normalize(path) {
  const out = [];
  for (const part of path.replace(/\\/g, '/').split('/')) {
    if (part === '' || part === '.') continue;
    if (part === '..') out.pop();
    else out.push(part);
  }
  return out.join('/');
}

async function validate({ name, bytes, files, base }) {
  const externalResourceFunction = async (uri) => {
    if (files) {
      const wanted = normalize(folderOf(name) + decodeURIComponent(uri));
      const file = files[wanted] ?? Object.entries(files).find(([path]) => path.split('/').pop() === wanted.split('/').pop())?.[1];
      if (!file) throw new Error(`${uri} was not among the dropped files`);
      return new Uint8Array(await file.arrayBuffer());
    }
    const response = await fetch(new URL(uri, base));
    if (!response.ok) throw new Error(`${uri}: HTTP ${response.status}`);
    return new Uint8Array(await response.arrayBuffer());
  };
  const main = bytes instanceof Blob ? await bytes.arrayBuffer() : bytes;
  return validator.validateBytes(new Uint8Array(main), {
    uri: name,
    maxIssues: 1000,
    writeTimestamp: false,
    externalResourceFunction,
  });
}

async function handle(data) {
  try {
    postMessage({ id: data.id, report: await validate(data) });
  } catch (e) {
    postMessage({ id: data.id, error: e instanceof Error ? e.message : String(e) });
  }
}

onmessage = ({ data }) => {
  if (data.validator) {
    try {
      validator = validatorFrom(data.validator);
    } catch (e) {
      // The element stops this worker and rejects what waits; its next validate() starts a new one.
      postMessage({ loadError: `the validator could not be loaded: ${e.message ?? e}` });
      return;
    }
    for (const request of queue.splice(0)) handle(request);
    return;
  }
  if (validator) handle(data);
  else queue.push(data);
};
