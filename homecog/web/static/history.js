"use strict";
// What the user told the robot (and what the household's hands taught it), and a picture of
// the household's switches by hand, day by day.

const KINDS = { explicit: "told", observed: "seen", undo: "undo" };

// A correction's kind: told here (explicit), a person's switch (observed), an undo of the robot's.
function correctionRow(c) {
  const badge = el("span", { class: "badge " + c.kind, title: c.weight > 1 ? `counts ${c.weight} times` : null }, KINDS[c.kind] ?? c.kind);
  let text;
  if (c.concerns) {  // a correction of some services only
    text = c.concerns.map((s) => sentence(words(s)) + (c.want.includes(s) ? " wanted" : " not wanted")).join(", ");
  } else {
    text = `${c.agreed ? "agreed" : "corrected"}: ${c.want.map(words).join(", ") || "nothing"}`;
  }
  return el("li", { "data-kind": c.kind }, badge, " ", text, c.weight > 1 ? el("span", { class: "why" }, ` ×${c.weight}`) : null);
}

const showHistory = serial(async () => {
  const who = user();
  const data = await api("GET", "/api/history?limit=50&user=" + encodeURIComponent(who));
  const last = data.agreement[data.agreement.length - 1];
  say("agreement", last
    ? `${who} told the robot ${plural(data.total, "time", "times")}; it had already agreed ${Math.round(last.rate * 100)} % of them.`
    : `${who} has told the robot nothing yet.`);
  $("history").replaceChildren(...data.corrections.slice(-8).reverse().map(correctionRow));
});

// The household's switches by hand per day (bars), the undos of the robot's actions among them
// darker; the day of the month under each bar, the count above it.
const DAYS = 14, WIDE = 320, TALL = 120, BASE = 100;

function dayBars(days) {
  const most = Math.max(1, ...days.map((d) => Math.max(d.switches, d.undos)));
  const step = WIDE / days.length, bar = step * 0.6;
  return days.flatMap((d, i) => {
    const x = i * step + (step - bar) / 2, high = (d.switches / most) * (BASE - 20), low = (d.undos / most) * (BASE - 20);
    const date = new Date(d.day + "T12:00:00");
    return [
      svgEl("rect", { class: "switched", x, y: BASE - high, width: bar, height: high, fill: "#9dbbdc", "data-day": d.day },
        svgEl("title", {}, `${d.day}: ${plural(d.switches, "switch", "switches")} by hand, ${plural(d.undos, "undo", "undos")}`)),
      svgEl("rect", { class: "undone", x, y: BASE - low, width: bar, height: low, fill: "#b03a2f" }),
      d.switches ? svgEl("text", { x: x + bar / 2, y: BASE - high - 3, "text-anchor": "middle" }, String(d.switches)) : null,
      svgEl("text", { x: x + bar / 2, y: BASE + 12, "text-anchor": "middle" }, String(date.getDate())),
    ].filter(Boolean);
  });
}

const showDays = serial(async () => {
  const { days } = await api("GET", `/api/switches?days=${DAYS}`);
  const svg = $("switches");
  svg.setAttribute("viewBox", `0 0 ${WIDE} ${TALL}`);
  svg.replaceChildren(svgEl("line", { x1: 0, y1: BASE, x2: WIDE, y2: BASE, stroke: "#d9dee5" }), ...dayBars(days));
  const all = days.reduce((n, d) => n + d.switches, 0), undos = days.reduce((n, d) => n + d.undos, 0);
  const first = days[0].day, last = days[days.length - 1].day;
  say("days-note", `${plural(all, "switch", "switches")} by hand from ${first} to ${last}; ` +
    `red: ${plural(undos, "time", "times")} the household undid the robot. Fewer is better: the robot does what it should.`);
});
