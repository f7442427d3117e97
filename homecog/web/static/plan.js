"use strict";
// The plan of the robot's suggestions, asked for by the user (never at every change of the
// home: a plan costs the server a second, and pages asking at every change got 429s), drawn
// on the floor plan like the paper's Fig. 15.

let planned = null;  // the services of the plan shown

const STEPS = {
  move: (a, b) => `go from the ${words(a)} to the ${words(b)}`,
  pick: (o, p) => `pick up the ${words(o)} at the ${words(p)}`,
  pour: (o, p) => `fill the ${words(o)} at the ${words(p)}`,
  hand_over: (o) => `hand the ${words(o)} over`,
  speak: (text) => `say “${text}”`,
  switch_iot: (d, s) => `switch the ${words(d)} ${s} (over the network)`,
  switch_by_hand: (d, s) => `switch the ${words(d)} ${s} by hand`,
  dock: (p) => `dock at the ${words(p)}`,
};
const step = ([name, ...args]) => (STEPS[name] ? STEPS[name](...args) : [name, ...args].map(words).join(" "));

function leaves(node) {
  return node.action ? [node] : node.children.flatMap(leaves);
}

function showPlan(plan) {  // each service with its steps, numbered in the order the robot does them
  $("plan").replaceChildren(...plan.tree.map((root) => el("li", { "data-service": root.task[0] },
    el("b", {}, sentence(words(root.task[0]))),
    el("ol", { class: "steps" }, ...leaves(root).map((a) => el("li", { value: a.index }, step(a.action)))))));
}

function planStale() {  // the suggestions changed since the plan was made
  const services = shown ? shown.data.services : [];
  $("plan-button").disabled = !home.layout || !services.length;
  if (planned !== null && JSON.stringify(planned) !== JSON.stringify(services)) {
    say("plan-note", "The suggestions changed since: show the plan again.");
  }
}

async function askPlan() {
  const button = $("plan-button");
  button.disabled = true;
  const services = shown.data.services, where = shown.context;
  say("plan-note", "Planning…");
  for (let tries = 0; ; tries++) {
    try {
      const plan = await api("POST", "/api/plan", { services, context: where });
      planned = services;
      showPlan(plan);
      drawTrajectory(home.layout, plan.simulation);
      say("plan-note", `The plan of the ${plural(services.length, "suggestion", "suggestions")} above.`);
      break;
    } catch (e) {
      if (e.status !== 429 || tries >= 2) { say("plan-note", e.message); break; }
      const wait = Math.min(Math.max(e.retryAfter || 1, 1), 5);  // the planner is busy: once more, soon
      say("plan-note", `The planner is busy; asking again in ${wait} s…`);
      await new Promise((done) => setTimeout(done, wait * 1000));
    }
  }
  planStale();
}
$("plan-button").addEventListener("click", askPlan);

// A label that would cover an earlier one is left out (its room or place keeps its name as a
// tooltip); one that would leave the floor plan is written leftwards.
function placeLabels(svg, labels, width) {
  const kept = [];
  for (const [text, shape] of labels) {
    let box = text.getBBox();
    if (box.x + box.width > width + 0.2) {
      setAttrs(text, { "text-anchor": "end", x: Number(text.getAttribute("x")) - 0.3 });
      box = text.getBBox();
    }
    if (kept.some((b) => box.x < b.x + b.width && b.x < box.x + box.width && box.y < b.y + b.height && b.y < box.y + box.height)) {
      text.remove();
      shape.append(svgEl("title", {}, text.textContent));
    } else kept.push(box);
  }
}

// The floor plan (metres, y up) and the robot's path through the plan.
function drawTrajectory(layout, sim) {
  const [w, h] = layout.size, y = (v) => +(h - v).toFixed(3), svg = $("trajectory");
  const line = ([x0, y0, x1, y1], stroke, width) =>
    svgEl("line", { x1: x0, y1: y(y0), x2: x1, y2: y(y1), stroke, "stroke-width": width });
  const labels = [];
  const parts = Object.entries(layout.rooms).flatMap(([name, [x0, y0, x1, y1]]) => {
    const room = svgEl("rect", { class: "room", x: x0, y: y(y1), width: x1 - x0, height: y1 - y0, fill: "#eef2f7" });
    const text = svgEl("text", { x: x0 + 0.15, y: y(y1) + 0.4 }, words(name));
    labels.push([text, room]);
    return [room, text];
  });
  parts.push(svgEl("rect", { width: w, height: h, fill: "none", stroke: "#1d2733", "stroke-width": 0.08 }));  // outer walls
  parts.push(...layout.walls.map((s) => line(s, "#1d2733", 0.08)));
  parts.push(...layout.doors.map((s) => line(s, "#eef2f7", 0.1)));
  parts.push(...Object.entries(layout.places).flatMap(([name, [px, py]]) => {
    const dot = svgEl("circle", { cx: px, cy: y(py), r: 0.1, fill: "#5b6878" });
    const text = svgEl("text", { x: px + 0.15, y: y(py) + 0.1 }, words(name));
    labels.push([text, dot]);
    return [dot, text];
  }));
  if (sim && sim.trajectory.length) {
    const points = sim.trajectory.map(([, px, py]) => `${px},${y(py)}`).join(" ");
    const [, sx, sy] = sim.trajectory[0], [, ex, ey] = sim.trajectory[sim.trajectory.length - 1];
    parts.push(svgEl("polyline", { id: "path", points, fill: "none", stroke: "#2f6fb0", "stroke-width": 0.07,
      "stroke-linejoin": "round" }),
      svgEl("circle", { cx: sx, cy: y(sy), r: 0.16, fill: "#2e8540" }),
      svgEl("circle", { cx: ex, cy: y(ey), r: 0.2, fill: "none", stroke: "#2f6fb0", "stroke-width": 0.07 }));
    say("route", `${plural(sim.timeline.length, "step", "steps")}, ${sim.seconds.toFixed(1)} s, ` +
      `${sim.distance_m.toFixed(1)} m driven (green: where the robot starts; ring: where it ends)`);
  } else { say("route"); }
  svg.setAttribute("viewBox", `-0.2 -0.2 ${w + 0.4} ${h + 0.4}`);
  svg.replaceChildren(...parts);
  svg.hidden = false;
  placeLabels(svg, labels, w);
}
