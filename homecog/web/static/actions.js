"use strict";
// What the robot did, when and why, each with its undo; and what the household did by hand.

const undoneHere = new Set();  // undone from this page (also those with nothing left to switch back)
const clock = (at) => new Date(at * 1000).toLocaleTimeString([], { hour: "2-digit", minute: "2-digit", hourCycle: "h23" });

function switchOf(s, undone) {
  const by = undone.get(s.device);
  return el("span", { class: "switch", "data-device": s.device },
    words(s.device), " → ", el("span", { class: s.state === "on" ? "on" : null }, s.state),
    by ? [" ", el("span", { class: "badge undone" }, by === "person" ? "undone by hand" : "undone here")] : null);
}

function actionRow(a) {
  const undone = new Map(a.undone.map((u) => [u.device, u.by]));
  const isUndone = undone.size > 0 || a.undone_here || undoneHere.has(a.id);
  const when = [a.home_time ? `${a.home_time} in the home (${clock(a.at)} here)` : clock(a.at), "for " + a.user].join(" · ");
  const switches = a.switches.map((s) => switchOf(s, undone));
  const what = switches.length ? switches : [el("span", { class: "why" }, a.actions.map(step).join("; ") || "no device switched")];
  if (isUndone && !undone.size) what.push(" ", el("span", { class: "badge undone" }, "undone here"));
  const why = a.why.map((e) => `${words(e.service)}: ${conditions(e)}`).join(" · ");
  const row = el("li", { "data-action": a.id, class: isUndone ? "undone" : null },
    el("div", {}, el("b", { class: "services", title: a.services.join(", ") }, a.services.map((s) => sentence(words(s))).join(", ")), " ",
      el("time", { class: "why", datetime: new Date(a.at * 1000).toISOString(), title: new Date(a.at * 1000).toLocaleString() }, when)),
    el("div", { class: "switches" }, ...what),
    why ? el("div", { class: "why reasons" }, "because " + why) : null);
  if (!isUndone) {
    const button = el("button", { type: "button", class: "undo", "aria-label": `undo action ${a.id}` }, "Undo");
    button.addEventListener("click", () => undo(a.id, button));
    row.append(button);
  }
  return row;
}

function householdLine(h) {
  const ignored = Object.entries(h.ignored).map(([k, v]) => `${words(k)} ${v}`).join(", ");
  const learned = h.learned;
  say("household", `People switched ${plural(h.household_switches, "device", "devices")} by hand. ` +
    `The robot learned from ${plural(learned.observed ?? 0, "switch", "switches")} by hand, ` +
    `${plural(learned.undo ?? 0, "undo", "undos")} and ${plural(learned.quiet ?? 0, "situation", "situations")} ` +
    `left as they were; it left a device alone ${plural(h.left_alone, "time", "times")} ` +
    `for the person who switched it (${plural(h.fights, "fight", "fights")}).`);
  setAttrs($("household"), { title: (ignored ? `not learned from: ${ignored}; ` : "") +
    `undo within ${h.undo_window_minutes} min; a person's switch left alone ${h.hold_minutes} min` });
}

const showActions = serial(async () => {
  const data = await api("GET", "/api/actions?limit=20");
  $("actions").replaceChildren(...data.actions.map(actionRow));
  $("no-actions").hidden = data.actions.length > 0;
  householdLine(data.household);
});

async function undo(id, button) {
  button.disabled = true; say(button, "Undoing…");
  const said = $("undo-result");
  try {
    const r = await api("POST", `/api/actions/${id}/undo`, { user: user() });
    undoneHere.add(id);
    say(said, `Undone for ${r.user}: ` +
      (r.switched.map((s) => `${words(s.device)} ${s.state}`).join(", ") || "nothing to switch back") +
      `; learned as not wanted here: ${r.rejected.map(words).join(", ") || "–"}.`);
  } catch (e) {
    if (e.status === 409) undoneHere.add(id);  // undone already (by hand, or elsewhere)
    else { button.disabled = false; say(button, "Undo"); }
    say(said, `Undo of action ${id}: ${e.message}`);
  }
  said.hidden = false;
  await Promise.allSettled([showActions(), refreshContext(), showHistory(), showDays()]);
}
