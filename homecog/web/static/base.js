"use strict";
// The page's base: text into the page, the API (with the token), and names as words.
//
// Off 127.0.0.1 every /api request needs the server's token. The page never keeps it: it hands
// it to POST /api/session once, which keeps it in an HttpOnly cookie that no script can read,
// this page's or one smuggled into it; the browser sends it with every /api request.
let home = null, context = null, asking = null;
const $ = (id) => document.getElementById(id);
const defaultUser = () => (home ? home.household.default_user : "default");
const user = () => $("user").value.trim() || defaultUser();

// The one place where text becomes page content: as text nodes and attribute values, never as
// markup. Every name from a home file or a user (rooms, places, values, units, user names,
// messages) reaches the page through el(), svgEl() or say(); attribute names are the code's own.
const PLAIN_ATTR = /^(?!on|href$|src$|style$|formaction$)[a-z][a-z0-9-]*$/;  // none runs or loads anything
function setAttrs(e, attrs) {
  for (const [k, v] of Object.entries(attrs)) {
    if (v === null || v === undefined || v === false) continue;
    if (!PLAIN_ATTR.test(k)) throw new Error("not an attribute the page sets: " + k);
    e.setAttribute(k, String(v));
  }
  return e;
}
const texts = (children) => children.flat().filter((c) => c !== null && c !== undefined && c !== false)
  .map((c) => (c instanceof Node ? c : String(c)));  // a string is appended as a text node
function el(tag, attrs = {}, ...children) {
  const e = setAttrs(document.createElement(tag), attrs);
  e.append(...texts(children));
  return e;
}
function svgEl(tag, attrs = {}, ...children) {
  const e = setAttrs(document.createElementNS("http://www.w3.org/2000/svg", tag), attrs);
  e.append(...texts(children));
  return e;
}
function say(target, ...children) {  // an element's whole content, as text
  const e = typeof target === "string" ? $(target) : target;
  e.replaceChildren(...texts(children));
  return e;
}

// A name of the home file as words: "ceiling_light" → "ceiling light", "TurnOnTVL" → "Turn on
// TVL". A name that is not an identifier stays as it is (as text, like every name).
function words(name) {
  if (!/^[A-Za-z0-9_]+$/.test(name)) return name;
  const parts = name.split("_").filter(Boolean)
    .flatMap((p) => p.match(/[A-Z]+(?![a-z])|[A-Z]?[a-z]+|\d+/g) || [p]);
  return parts.map((w, i) => (i > 0 && /^[A-Z][a-z]/.test(w) ? w.toLowerCase() : w)).join(" ") || name;
}
const sentence = (text) => text.charAt(0).toUpperCase() + text.slice(1);
const plural = (n, one, many) => `${n} ${n === 1 ? one : many}`;

// One run at a time; calls while it runs make one more run after it (the newest answer wins).
function serial(fn) {
  let running = null, again = false;
  return () => {
    if (running) { again = true; return running; }
    running = (async () => {
      try { do { again = false; await fn(); } while (again); } finally { running = null; }
    })();
    return running;
  };
}

// At most one run every `ms` milliseconds, the last call always followed by a run: what many
// events ask for (the home changes every second in a simulated home) is asked for once.
function atMostEvery(ms, fn) {
  let timer = null, last = 0;
  return () => {
    if (timer) return;
    const wait = Math.max(0, last + ms - Date.now());
    timer = setTimeout(() => { timer = null; last = Date.now(); fn(); }, wait);
  };
}

async function keepToken(given) {  // the server keeps it in an HttpOnly cookie for this browser
  const r = await fetch("/api/session", { method: "POST", headers: { authorization: "Bearer " + given } });
  if (!r.ok) throw new Error(r.status === 401 ? "that is not this server's token" : r.statusText);
}

function askToken() {  // one question however many requests were refused at once
  asking ??= Promise.resolve().then(async () => {
    const given = prompt("This robot needs its token (homecog up printed it):");
    if (!given) throw new Error("no token: this server needs one");
    await keepToken(given.trim());
  }).finally(() => { asking = null; });
  return asking;
}

async function api(method, path, body, retry = true) {
  const r = await fetch(path, { method, headers: { "content-type": "application/json" },
    body: body ? JSON.stringify(body) : undefined });
  if (r.status === 401 && retry) { await askToken(); return api(method, path, body, false); }
  const data = await r.json();
  if (!r.ok) {
    const detail = typeof data.detail === "string" ? data.detail : JSON.stringify(data.detail);
    throw Object.assign(new Error(detail || r.statusText), { status: r.status, retryAfter: +r.headers.get("retry-after") });
  }
  return data;
}
