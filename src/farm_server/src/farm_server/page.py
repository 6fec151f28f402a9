"""The farm page served at ``/``: one static HTML document that renders /api/v1/overview.

Query string: ``?day=YYYY-MM-DD`` (default today). No external resources (the farm network may
be offline), so it renders the same in a headless browser.
"""

__all__ = ['PAGE_HTML']

PAGE_HTML = r"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>Harvest farm server</title>
<style>
  body { font-family: "DejaVu Sans", Arial, sans-serif; margin: 20px 28px; color: #222;
         background: #fafaf7; }
  h1 { font-size: 22px; margin: 0 0 4px 0; }
  h2 { font-size: 17px; margin: 22px 0 8px 0; border-bottom: 1px solid #ccc; }
  .sub { color: #666; font-size: 13px; }
  .strip { display: flex; gap: 3px; margin: 6px 0 2px 0; flex-wrap: wrap; }
  .cell { width: 40px; height: 46px; border: 1px solid #999; border-radius: 3px;
          display: flex; flex-direction: column; align-items: center; justify-content: center;
          font-size: 12px; position: relative; }
  .cell .n { font-size: 16px; font-weight: bold; }
  .cell.plan { outline: 3px solid #1565c0; outline-offset: 1px; }
  .cell .k { font-size: 10px; color: #333; }
  .legend { font-size: 12px; color: #444; margin: 4px 0 0 0; }
  .legend span { display: inline-block; width: 14px; height: 12px; border: 1px solid #999;
                 vertical-align: middle; margin: 0 3px 0 10px; }
  table { border-collapse: collapse; font-size: 13px; margin-top: 4px; }
  th, td { border: 1px solid #ccc; padding: 4px 9px; text-align: right; }
  th { background: #eee; }
  td.l, th.l { text-align: left; }
  .rowname { font-weight: bold; margin-top: 10px; font-size: 14px; }
  .empty { color: #888; font-style: italic; }
  #error { color: #b00; }
</style>
</head>
<body>
<h1>Harvest farm server</h1>
<div class="sub" id="subtitle">loading&hellip;</div>
<div id="error"></div>
<h2>Track: expected ripe fruit per picking point</h2>
<div id="strips"></div>
<div class="legend">fruit forecast ripe at the start of work:
  <span style="background:#f1f8e9"></span>0 <span style="background:#ffcc80"></span>1-2
  <span style="background:#ff7043"></span>3-4 <span style="background:#c62828"></span>5+
  <span style="outline:3px solid #1565c0;background:#fff"></span>in a robot's plan
  &nbsp;(small figure: point index; &#9650; tomorrow's forecast)</div>
<h2>Plans for the day</h2>
<div id="plans"></div>
<h2>Harvest per robot</h2>
<div id="robots"></div>
<h2>Yield per row</h2>
<div id="rows"></div>
<script>
"use strict";
function el(tag, attrs, children) {
  var e = document.createElement(tag);
  Object.keys(attrs || {}).forEach(function (k) { e.setAttribute(k, attrs[k]); });
  (children || []).forEach(function (c) {
    e.appendChild(typeof c === "string" ? document.createTextNode(c) : c);
  });
  return e;
}
function colour(n) {
  if (n <= 0) return "#f1f8e9";
  if (n <= 2) return "#ffcc80";
  if (n <= 4) return "#ff7043";
  return "#c62828";
}
function fmt(v, digits) { return v === null || v === undefined ? "-" : v.toFixed(digits); }
function when(t) { return t ? new Date(t * 1000).toISOString().replace("T", " ").slice(0, 16) : "-"; }
function table(head, rows, left) {
  var t = el("table", {}, [el("tr", {}, head.map(function (h, i) {
    return el("th", i < left ? {"class": "l"} : {}, [h]); }))]);
  rows.forEach(function (r) {
    t.appendChild(el("tr", {}, r.map(function (v, i) {
      return el("td", i < left ? {"class": "l"} : {}, [String(v)]); })));
  });
  return t;
}
function render(data) {
  document.getElementById("subtitle").textContent = "Day " + data.day +
    " \u2014 start of work " + when(data.start_of_work) + " UTC \u2014 ripe at score \u2265 " +
    data.model.ripe_score + ", default ripening " + data.model.default_rate + "/day";
  var planned = {};
  data.robots.forEach(function (r) {
    if (r.plan) r.plan.picking_points.forEach(function (k) {
      planned[r.plan.row + "/" + k] = true; });
  });
  var strips = document.getElementById("strips");
  if (!data.rows.length) strips.appendChild(el("div", {"class": "empty"}, ["no records yet"]));
  data.rows.forEach(function (row) {
    strips.appendChild(el("div", {"class": "rowname"}, ["Row " + row.row]));
    var strip = el("div", {"class": "strip", "data-row": row.row}, []);
    row.points.forEach(function (p) {
      var cls = "cell" + (planned[row.row + "/" + p.picking_point] ? " plan" : "");
      var c = el("div", {"class": cls, "data-point": p.picking_point,
                         "data-ripe": p.expected_ripe,
                         "title": "point " + p.picking_point + " at " + p.track_position +
                                  " m: " + p.expected_ripe + " ripe of " + p.fruit_present +
                                  " fruit, last scan " + when(p.last_scan)},
                 [el("span", {"class": "n"}, [String(p.expected_ripe)]),
                  el("span", {"class": "k"}, [p.picking_point + " \u25b2" +
                                               p.expected_ripe_tomorrow])]);
      c.style.background = colour(p.expected_ripe);
      if (p.expected_ripe >= 5) c.style.color = "#fff";
      strip.appendChild(c);
    });
    strips.appendChild(strip);
  });
  var plans = data.robots.filter(function (r) { return r.plan; }).map(function (r) {
    return [r.robot, r.plan.row, r.plan.picking_points.join(", ") || "(nothing to pick)",
            r.plan.expected_ripe];
  });
  document.getElementById("plans").appendChild(plans.length ?
    table(["robot", "row", "picking points in visit order", "expected ripe"], plans, 3) :
    el("div", {"class": "empty"}, ["no plans"]));
  document.getElementById("robots").appendChild(table(
    ["robot", "missions", "picked", "picked today", "unreachable", "lost", "failed", "dropped",
     "success", "mean cycle time [s]", "last upload (UTC)"],
    data.robots.map(function (r) {
      var o = r.outcomes || {};
      return [r.robot, r.missions, r.picked, r.picked_today, o.unreachable || 0, o.lost || 0,
              o.failed || 0, o.dropped || 0,
              r.success_rate === null ? "-" : Math.round(100 * r.success_rate) + " %",
              fmt(r.mean_cycle_time, 1), when(r.last_upload)];
    }), 1));
  document.getElementById("rows").appendChild(data.yield_by_row.length ? table(
    ["row", "picked", "picked today", "attempts"],
    data.yield_by_row.map(function (w) { return [w.row, w.picked, w.picked_today, w.attempts]; }),
    1) : el("div", {"class": "empty"}, ["no pick records yet"]));
  document.body.setAttribute("data-ready", "1");
}
var day = new URLSearchParams(window.location.search).get("day");
fetch("/api/v1/overview" + (day ? "?day=" + encodeURIComponent(day) : ""))
  .then(function (r) { if (!r.ok) throw new Error("HTTP " + r.status); return r.json(); })
  .then(render)
  .catch(function (e) {
    document.getElementById("error").textContent = "cannot load the overview: " + e;
    document.body.setAttribute("data-ready", "error");
  });
</script>
</body>
</html>
"""
