"use strict";
// The page starts: the home, the user, one event stream. The page never polls the robot:
// everything after the first answers comes from the stream, and what many events ask for at
// once (the simulated home changes every second) is asked for at most every few seconds.

async function refreshContext() {
  context = await api("GET", "/api/context"); showContext(); await cognize();
}

const actionsSoon = atMostEvery(5000, () => showActions());  // held devices, fights, left alone
const daysSoon = atMostEvery(10000, () => showDays());

function whoChanged() {
  answered.clear(); drawn = "";
  cognize(); showHistory();
}
$("user").addEventListener("change", whoChanged);

// a real home's connection (Home Assistant, MQTT), checked every few seconds
async function source() {
  try {
    const s = await api("GET", "/api/source");
    if (s.kind === "simulated" || s.kind === "manual") return;
    const name = s.kind === "home_assistant" ? `Home Assistant${s.version ? " " + s.version : ""}` : "MQTT";
    const skipped = s.skipped ? ` · ${plural(s.skipped, "state", "states")} skipped` : "";
    say("source", s.connected ? `${name}: connected${skipped}` : `${name}: reconnecting…`);
    setAttrs($("source"), { title: s.last_error || "", class: s.connected ? "" : "down" });  // the reason on hover
    $("source").hidden = false;
  } catch (e) { say("source", "source: " + e.message); $("source").hidden = false; }
  setTimeout(source, 3000);
}

function listen() {
  const events = new EventSource("/api/events");  // the token's cookie goes with it
  events.addEventListener("context", async (ev) => {
    context = JSON.parse(ev.data); showContext(); actionsSoon(); await cognize();
  });
  // the robot switched devices: its context event may come later (or not, where it acted by itself)
  events.addEventListener("action", () => { showActions(); refreshContext(); });
  events.addEventListener("correction", (ev) => {  // told, or learned from the household's hands
    const c = JSON.parse(ev.data);
    showActions(); showHistory(); daysSoon();  // an undo by hand marks the robot's action
    if (c.kind !== "explicit" && c.user === user()) cognize();  // the robot's suggestions may change
  });
  events.onopen = () => { say("status", "live"); showActions(); };  // also after a reconnect
  events.onerror = () => { say("status", "reconnecting…"); };
}

(async () => {
  const given = new URLSearchParams(location.search).get("token");  // homecog up's link may carry it
  if (given !== null) { window.history.replaceState(null, "", location.pathname); await keepToken(given); }
  const kept = localStorage.getItem("homecog-token");  // where an earlier page kept it: moved to the cookie
  if (kept !== null) { localStorage.removeItem("homecog-token"); await keepToken(kept).catch(() => {}); }
  home = await api("GET", "/api/home");
  say("home-name", home.name);
  $("user").value = home.household.default_user;
  $("users").replaceChildren(...(home.household.users || [home.household.default_user]).map((u) => el("option", { value: u })));
  showChoices();
  if (home.layout) drawTrajectory(home.layout, null); else $("plan-panel").hidden = true;
  context = await api("GET", "/api/context");
  showContext(); await cognize(); await showHistory(); await showActions(); await showDays(); source();
  listen();
})();
