"use strict";
// The robot's suggestions, each with its own yes or no (nothing is ticked for the user): a yes
// is learned as that service wanted here, a no as not wanted here, never the whole list.

let shown = null;  // the cognition on the page: {context, user, data}
let drawn = "";  // what the list shows, so that an unchanged answer leaves it (and a finger) alone
const answered = new Map();  // service → "yes" | "no", for the user in the situation `answeredIn`
let answeredIn = "";

// A service's chance of being wanted now (the answer's `probabilities`), in words and as a number.
function chance(p) {
  if (typeof p !== "number" || !Number.isFinite(p)) return null;
  const said = p >= 0.9 ? "very likely" : p >= 0.7 ? "likely" : p >= 0.4 ? "maybe" : "unlikely";
  return `${said}, ${p.toFixed(2)}`;
}

// What the answering knowledge matched, its names as words ("location: sofa, dining table").
const conditions = (e) => Object.entries(e.conditions || {})
  .map(([k, v]) => `${words(k)}: ${String(v).replaceAll("_", " ")}`).join("; ") || "always";

// Why, in words: whose corrections answered (and how many of them agree), or what was learned.
function because(e) {
  if (e.user) {
    const agree = e.evidence ? ` (${e.evidence.agreed} of ${e.evidence.agreed + e.evidence.disagreed} agree)` : "";
    return `learned from ${e.user}'s corrections${agree}: ${conditions(e)}`;
  }
  return `learned from experience: ${conditions(e)}`;
}

function answerButtons(service) {
  const yes = el("button", { type: "button", class: "yes", "aria-label": `yes, ${words(service)}` }, "Yes");
  const no = el("button", { type: "button", class: "no", "aria-label": `no, ${words(service)}` }, "No");
  yes.addEventListener("click", () => answer(service, "yes", [yes, no]));
  no.addEventListener("click", () => answer(service, "no", [yes, no]));
  return el("span", { class: "answer" }, yes, no);
}

function proposalRow(e, probabilities) {
  const said = answered.get(e.service);
  const odds = chance((probabilities || {})[e.service]);
  return el("li", { "data-service": e.service },
    el("b", { class: "name", title: e.service }, sentence(words(e.service))),
    odds ? el("span", { class: "chance" }, odds) : null,
    el("span", { class: "why" }, because(e)),
    said ? el("span", { class: "said " + said }, said === "yes" ? "You said yes" : "You said no") : answerButtons(e.service),
    el("span", { class: "note", hidden: true }));
}

function showProposals(data) {
  const now = situation(shown.context) + "\u0000" + shown.user;
  if (now !== answeredIn) { answered.clear(); answeredIn = now; }
  const key = JSON.stringify([now, data.explanations, data.probabilities, [...answered]]);
  $("unknown").hidden = !data.unknown;
  if (key === drawn) return;
  drawn = key;
  const items = data.explanations.map((e) => proposalRow(e, data.probabilities));
  $("services").replaceChildren(...(items.length ? items : [el("li", { class: "none" }, "Nothing to do now.")]));
  planStale();
}

const cognize = serial(async () => {
  const asked = { context, user: user() };
  const data = await api("POST", "/api/cognize", asked);
  shown = { ...asked, data };
  showProposals(data);
  document.body.dataset.cognitions = (+document.body.dataset.cognitions || 0) + 1;  // for tests and tools
});

async function answer(service, said, buttons) {
  buttons.forEach((b) => { b.disabled = true; });
  const row = [...$("services").children].find((li) => li.dataset.service === service);
  try {
    await api("POST", "/api/answers", { context: shown.context, service, answer: said, user: shown.user });
    answered.set(service, said);
  } catch (e) {
    buttons.forEach((b) => { b.disabled = false; });
    if (row) { const note = row.querySelector(".note"); say(note, e.message); note.hidden = false; }
    if (e.status === 409) { drawn = ""; }  // no longer pending: the robot's current suggestions
  }
  await cognize();
  showHistory();
}

// Services the robot did not suggest, asked for: each ticked one is learned as wanted here too.
function showChoices() {
  $("choices").replaceChildren(...home.services.map((s) =>
    el("label", { title: s.name }, el("input", { type: "checkbox", value: s.name, name: "want" }), el("span", {}, sentence(words(s.name))))));
}

$("correction").addEventListener("submit", async (ev) => {
  ev.preventDefault();
  const boxes = [...document.querySelectorAll("#choices input:checked")];
  if (!boxes.length) { say("corrected", "Tick what you want here first."); return; }
  const change = Object.fromEntries(boxes.map((b) => [b.value, "add"]));
  try {
    const r = await api("POST", "/api/corrections", { context, change, user: user() });
    boxes.forEach((b) => { b.checked = false; });
    say("corrected", `Learned, for ${r.user}: wanted here too: ${boxes.map((b) => words(b.value)).join(", ")}.`);
    await cognize(); await showHistory();
  } catch (e) { say("corrected", e.message); }
});
