// cocobench view: filtering and sorting the runs page, polling a live run for new
// episodes, the prompt toggles of an episode page and the two columns of a compare page.
// Plain JavaScript, no build step, no network beyond the viewer's own server.
(function () {
  "use strict";
  var body = document.body;
  var root = body.dataset.root || "";

  // The runs page: every row lives in one array (from the page's JSON, then the live
  // server); the table shows the filtered, sorted rows a page at a time, so a run of
  // thousands of episodes stays fast.
  var PAGE = 500;
  var table = document.getElementById("episodes");
  var data = table ? JSON.parse(document.getElementById("rows-data").textContent) : null;
  var rows = data ? data.rows : [], byKey = {}, shownLimit = PAGE, order = null;
  var columns = data ? data.columns : [];
  rows.forEach(function (r, i) { byKey[r.k] = i; });

  function escapeHtml(text) {
    return String(text).replace(/[&<>"']/g, function (c) {
      return { "&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&#39;" }[c];
    });
  }

  function cellHtml(row, i) {
    var v = escapeHtml(row.v[i]), key = columns[i];
    if (key === "task_id") {
      return '<td class="instance"><a href="' + escapeHtml(root + row.h) + '">' + v +
        '</a> <a class="cmp" title="compare this instance across models, conditions and arms" href="' +
        escapeHtml(root + row.c) + '">⇄</a></td>';
    }
    var cls = key === "success" ? (v === "yes" ? "ok" : "bad")
      : key === "errors" && v !== "none" ? "bad" : "";
    return "<td" + (cls ? ' class="' + cls + '"' : "") + ">" + v + "</td>";
  }

  function sortValue(text) {
    var n = Number(text);
    return text === "" ? -Infinity : isNaN(n) ? text : n;
  }

  function render() {
    var wanted = [];
    document.querySelectorAll("select[data-filter]").forEach(function (s) {
      if (s.value) wanted.push([columns.indexOf(s.dataset.filter), s.value]);
    });
    var needle = (document.getElementById("search").value || "").toLowerCase();
    var task = columns.indexOf("task_id");
    var picked = rows.filter(function (r) {
      for (var i = 0; i < wanted.length; i++) if (r.v[wanted[i][0]] !== wanted[i][1]) return false;
      return !needle || r.v[task].toLowerCase().indexOf(needle) >= 0;
    });
    if (order) {
      var i = order.index, sign = order.ascending ? 1 : -1;
      picked = picked.map(function (r) { return [sortValue(r.v[i]), r]; });
      picked.sort(function (a, b) {
        var x = a[0], y = b[0];
        var c = typeof x === typeof y ? (x < y ? -1 : x > y ? 1 : 0) : typeof x === "number" ? -1 : 1;
        return sign * c;
      });
      picked = picked.map(function (p) { return p[1]; });
    }
    var html = [];
    picked.slice(0, shownLimit).forEach(function (r) {
      var cells = [];
      for (var i = 0; i < columns.length; i++) cells.push(cellHtml(r, i));
      html.push('<tr data-key="' + escapeHtml(r.k) + '">' + cells.join("") + "</tr>");
    });
    table.tBodies[0].innerHTML = html.join("");
    var shown = Math.min(picked.length, shownLimit);
    document.getElementById("shown-count").firstChild.nodeValue =
      (shown < picked.length ? shown + " displayed of " + picked.length + " matching, " : picked.length + " of ");
    document.getElementById("episode-count").textContent = rows.length;
    document.getElementById("more").hidden = shown >= picked.length;
    document.getElementById("no-episodes").hidden = rows.length > 0;
  }

  function sortBy(th) {
    var index = columns.indexOf(th.dataset.key);
    var ascending = !(order && order.index === index && order.ascending);
    order = { index: index, ascending: ascending };
    table.querySelectorAll("th").forEach(function (h) { delete h.dataset.order; });
    th.dataset.order = ascending ? "asc" : "desc";
    render();
  }

  function addOption(select, value) {
    for (var i = 0; i < select.options.length; i++) if (select.options[i].value === value) return;
    var option = document.createElement("option");
    option.textContent = value;
    select.appendChild(option);
  }

  function poll() {
    fetch(root + "api/rows?since=" + table.dataset.seq, { cache: "no-store" })
      .then(function (r) { return r.ok ? r.json() : Promise.reject(r.status); })
      .then(function (fresh) {
        fresh.rows.forEach(function (row) {
          if (row.k in byKey) rows[byKey[row.k]] = row;
          else { byKey[row.k] = rows.length; rows.push(row); }
          document.querySelectorAll("select[data-filter]").forEach(function (s) {
            addOption(s, row.v[columns.indexOf(s.dataset.filter)]);
          });
        });
        table.dataset.seq = fresh.seq;
        if (fresh.rows.length) render();
      })
      .catch(function () { /* the server is gone or busy: try again on the next tick */ })
      .finally(function () { setTimeout(poll, 2000); });
  }

  if (table) {
    document.querySelectorAll("select[data-filter]").forEach(function (s) {
      s.addEventListener("change", function () { shownLimit = PAGE; render(); });
    });
    document.getElementById("search").addEventListener("input", function () { shownLimit = PAGE; render(); });
    document.getElementById("show-more").addEventListener("click", function () {
      shownLimit += PAGE * 4; render();
    });
    table.querySelectorAll("th").forEach(function (th) {
      th.addEventListener("click", function () { sortBy(th); });
    });
    render();
    if (body.dataset.live === "true") setTimeout(poll, 2000);
  }

  function showColumns() {
    var picked = {};
    document.querySelectorAll("#compare-pick select").forEach(function (s) { picked[s.value] = true; });
    document.querySelectorAll("[data-col]").forEach(function (el) {
      el.style.display = picked[el.dataset.col] ? "" : "none";
    });
  }

  function toggle(open) {
    document.querySelectorAll("details.prompt").forEach(function (d) { d.open = open; });
  }
  var expand = document.getElementById("expand-prompts");
  if (expand) expand.addEventListener("click", function () { toggle(true); });
  var collapse = document.getElementById("collapse-prompts");
  if (collapse) collapse.addEventListener("click", function () { toggle(false); });

  var pick = document.getElementById("compare-pick");
  if (pick) {
    pick.querySelectorAll("select").forEach(function (s) { s.addEventListener("change", showColumns); });
    showColumns();
  }
})();
