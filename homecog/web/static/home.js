"use strict";
// The home now: the readings with their units and bins, then the devices room by room.

const featureNamed = (name) => home.features.find((f) => f.name === name);
const clockHours = (v) => {  // "HH:MM[:SS]" or decimal hours, as the API writes a clock
  if (typeof v === "number") return v;
  const [h, m = 0, s = 0] = String(v).split(":").map(Number);
  return h + m / 60 + s / 3600;
};

// The bin a clock or numeric reading falls in ([low, high), a clock's wrapping midnight where
// low > high), as the server's own discretization; -1 outside every bin.
function binOf(f, v) {
  const x = f.kind === "clock" ? clockHours(v) : Number(v);
  return f.bins.findIndex(([low, high]) => {
    const lo = low ?? -Infinity, hi = high ?? Infinity;
    return lo < hi ? lo <= x && x < hi : x >= lo || x < hi;
  });
}

// Where the user is and what the devices are in the robot's eyes: a proposal answered stays
// answered while this stays the same (the server keeps it so too).
function situation(ctx) {
  return JSON.stringify(Object.entries(ctx).map(([name, v]) => {
    const f = featureNamed(name);
    return f && f.bins ? binOf(f, v) : v;
  }));
}

const number = (x) => String(Math.round(Number(x) * 10) / 10);

// A reading as people say it: "19.5 °C (cold)", "22:00 (night)", "dining table".
function reading(f, v) {
  if (f.kind === "categorical") return [words(String(v))];
  const shown = f.kind === "clock" ? String(v) : number(v) + (f.unit ? " " + f.unit : "");
  const k = binOf(f, v);
  return [shown, k >= 0 ? el("span", { class: "bin" }, ` (${words(f.values[k])})`) : null];
}

function row(name, ...value) {
  return el("tr", {}, el("td", {}, words(name)), el("td", { "data-name": name }, ...value));
}

function deviceRow(name, state) {
  return el("tr", {}, el("td", {}, words(name)), el("td", { class: state === "on" ? "on" : null, "data-name": name }, state));
}

// The devices by room, rooms in the order the home file first names them; those without a
// room last.
function rooms() {
  const out = new Map();
  for (const d of home.devices) {
    const room = d.room ?? "";
    if (!out.has(room)) out.set(room, []);
    out.get(room).push(d.name);
  }
  const none = out.get("");
  out.delete("");
  if (none) out.set("", none);
  return out;
}

function showContext() {
  const readings = el("tbody", { class: "readings" }, ...home.features.map((f) => row(f.name, ...reading(f, context[f.name]))));
  const groups = [...rooms()].map(([room, devices]) => el("tbody", { "data-room": room },
    el("tr", { class: "room" }, el("th", { colspan: 2, scope: "rowgroup" }, room ? sentence(words(room)) : "Other devices")),
    ...devices.map((d) => deviceRow(d, context[d]))));
  $("context").replaceChildren(readings, ...groups);
}
