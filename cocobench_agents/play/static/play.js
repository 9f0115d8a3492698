// cocobench play: draws the pending decision of a human seat and sends the person's choice.
// The state comes by long polling (the server answers when it changes); every text is set
// with textContent, never parsed as HTML (prompts and messages are not ours).
"use strict";
(() => {
  const $ = (id) => document.getElementById(id);
  const token = new URLSearchParams(location.search).get("token") || "";
  const auth = { [document.body.dataset.tokenHeader]: token };
  const PART_TITLES = [["goal", "Goal"], ["progress", "Goal progress"],
    ["messages", "Teammates' messages"], ["history", "Recent actions"], ["state", "State"]];
  let version = null;   // the version of the state drawn last
  let decision = null;  // the decision on screen (null: none pending)
  let typed = "";       // digits typed for a keyboard choice
  let sending = false;

  const pause = (ms) => new Promise((resolve) => setTimeout(resolve, ms));

  function element(tag, text, className) {
    const node = document.createElement(tag);
    if (text !== undefined) node.textContent = text;
    if (className) node.className = className;
    return node;
  }

  function show(id, text) {
    $(id).textContent = text || "";
    $(id).hidden = !text;
  }

  function episodeName(key) {
    if (!key) return "";
    const arm = key.arm ? ` · arm ${key.arm}` : "";
    const epoch = key.epoch ? ` · epoch ${key.epoch}` : "";
    return `${key.task_id} · ${key.model} · ${key.condition}${arm}${epoch}`;
  }

  function score(value) {
    return value === null || value === undefined ? "–" : Number(value).toFixed(2);
  }

  function drawRun(state) {
    const run = state.run;
    if (state.ended !== null) {
      $("run-status").textContent = "the run has ended";
    } else if (run.total === undefined) {
      $("run-status").textContent = "waiting for the run to start…";
    } else {
      const current = Math.min(run.done + state.outcomes.length + 1, run.total);
      $("run-status").textContent = `episode ${current} of ${run.total}`;
    }
    show("ended", state.ended === null ? "" :
      `The run has ended: ${state.ended}. Its summary and exit code are in the terminal ` +
      "where cocobench run was started.");
  }

  function drawOutcomes(outcomes) {
    const body = $("outcomes").querySelector("tbody");
    body.replaceChildren(...outcomes.map((o) => {
      const row = element("tr");
      const construct = o.construct_score === null ? (o.construct_status || "–") :
        `${score(o.construct_score)} (${o.dim})`;
      for (const cell of [o.task_id, o.condition, o.task_success ? "✓ success" : "✗ failed",
        score(o.task_progress), construct, o.infra_error ? `error: ${o.infra_error}` :
          o.terminal_reason, o.num_steps]) {
        row.append(element("td", String(cell ?? "–")));
      }
      return row;
    }));
    $("outcomes").hidden = outcomes.length === 0;
    $("no-outcomes").hidden = outcomes.length > 0;
    const last = outcomes[outcomes.length - 1];
    show("last-outcome", last && (
      `Episode finished: ${last.task_id} (${last.condition}) — ` +
      `${last.task_success ? "success" : "not solved"}, construct score ` +
      `${last.construct_score === null ? last.construct_status : score(last.construct_score)}` +
      `, ${last.terminal_reason}.`));
  }

  function drawDecision(state) {
    const next = state.decision;
    if (next && decision && next.id === decision.id) return;  // keep what is being typed
    decision = next;
    typed = "";
    show("typed", "");
    $("reason").value = "";
    $("message").value = "";
    if (!decision) {
      const ended = state.ended !== null;
      $("seat-title").textContent = ended ? "No more decisions" : "Waiting for the next decision…";
      $("episode-title").textContent = episodeName(state.episode);
      $("frames").replaceChildren();
      $("parts").replaceChildren();
      $("menu").replaceChildren();
      delete $("menu").dataset.decision;
      $("controls").hidden = true;
      $("prompt-box").hidden = true;
      $("choose").hidden = ended;
      return;
    }
    $("seat-title").textContent = `${decision.seat === "team" ? "The team's planner" :
      decision.seat}: your decision (step ${decision.step_index + 1})`;
    $("episode-title").textContent = episodeName(state.episode) || decision.episode;
    $("frames").replaceChildren(...decision.images.map((src, i) => {
      const image = element("img");
      image.src = src;
      image.alt = `frame ${i + 1} of ${decision.images.length}: what ${decision.seat} sees`;
      return image;
    }));
    $("parts").replaceChildren(...PART_TITLES.filter(([key]) => decision.parts[key] !== undefined)
      .map(([key, title]) => {
        const card = element("section", undefined, `card part-${key}`);
        card.append(element("h3", title), element("pre", decision.parts[key]));
        return card;
      }));
    $("prompt").textContent = decision.prompt;
    $("prompt-box").hidden = false;
    $("message-field").hidden = !decision.wants_message;
    $("menu").dataset.decision = decision.id;
    $("menu").replaceChildren(...decision.menu.map((option) => {
      const button = element("button", `${option.id}: ${option.label}`);
      button.type = "button";
      button.dataset.id = option.id;
      button.title = option.call;
      button.addEventListener("click", () => choose(option.id));
      return button;
    }));
    $("controls").hidden = false;
    setMenuEnabled(true);
    show("sent", "");
  }

  function draw(state) {
    drawRun(state);
    drawOutcomes(state.outcomes);
    drawDecision(state);
  }

  function setMenuEnabled(enabled) {
    for (const button of $("menu").querySelectorAll("button")) button.disabled = !enabled;
    $("done").disabled = !enabled;
  }

  // actionId null: DONE (every goal is satisfied), as a model may answer
  async function choose(actionId) {
    if (sending || !decision) return;
    const asked = decision;
    sending = true;
    setMenuEnabled(false);
    const body = { decision: asked.id, action_id: actionId, reason: $("reason").value,
      message: asked.wants_message ? $("message").value : "" };
    try {
      const response = await fetch("/play/api/answer", {
        method: "POST", headers: { ...auth, "Content-Type": "application/json" },
        body: JSON.stringify(body) });
      const reply = await response.json();
      if (response.ok) {
        show("sent", `Sent ${actionId ?? "DONE"}. Waiting for the next decision…`);
      } else {
        show("sent", `Not taken: ${reply.error}`);
        if (decision === asked && response.status !== 409) setMenuEnabled(true);
      }
    } catch (error) {
      show("sent", `Not sent (${error.message}); try again.`);
      if (decision === asked) setMenuEnabled(true);
    } finally {
      sending = false;
    }
  }

  function onKey(event) {
    if (!decision || event.altKey || event.ctrlKey || event.metaKey) return;
    if (event.target.closest("input, textarea")) return;  // typing a reason or a message
    if (/^[0-9]$/.test(event.key)) {
      typed += event.key;
    } else if (event.key === "Backspace") {
      typed = typed.slice(0, -1);
    } else if (event.key === "Escape") {
      typed = "";
    } else if (event.key === "Enter" && typed) {
      const id = Number(typed);
      typed = "";
      if (decision.menu.some((option) => option.id === id)) choose(id);
      else show("sent", `${id} is not on the menu.`);
    } else {
      return;
    }
    event.preventDefault();
    show("typed", typed && `Action ${typed} — press Enter to choose it`);
    for (const button of $("menu").querySelectorAll("button")) {
      button.classList.toggle("typed", button.dataset.id === typed);
    }
  }

  async function follow() {
    for (;;) {
      try {
        const query = version === null ? "" : `?after=${version}`;
        const response = await fetch(`/play/api/state${query}`, { headers: auth,
          cache: "no-store" });
        const state = await response.json();
        if (!response.ok) {
          show("problem", state.error);
          return;  // a wrong token stays wrong
        }
        show("problem", "");
        version = state.version;
        draw(state);
        if (state.ended !== null) return;
      } catch (error) {
        // The server stops with the run: a page that missed the last word learns it here.
        show("problem", "cocobench run is not answering: the run has ended or was stopped " +
          "(its summary is in the terminal; resume a stopped run with cocobench run --out " +
          "RUN --resume). Retrying…");
        await pause(2000);
      }
    }
  }

  $("done").addEventListener("click", () => choose(null));
  document.addEventListener("keydown", onKey);
  follow();
})();
