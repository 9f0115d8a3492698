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
  let version = null;     // the version of the state drawn last
  let decision = null;    // the decision on screen (null: none pending)
  let typed = "";         // digits typed for a keyboard choice
  let sending = false;    // an answer is on its way
  let answered = null;    // the id of the decision answered last (its menu stays off)
  let unreachable = false;  // the server does not answer (the run ended or was stopped)
  let tokenDead = false;  // the server refused this tab's token: a restarted run's new one
  let drawnAt = 0;        // when the menu on screen was drawn (performance.now())
  let pressedAt = -1;     // when the last pointer press began (an event's timeStamp)

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

  // What became of the person's choice; its line keeps its place, so the buttons never move
  // under the pointer.
  function say(text) {
    $("sent").textContent = text;
  }

  function episodeName(key) {
    if (!key) return "";
    const arm = key.arm ? ` · arm ${key.arm}` : "";
    const epoch = key.epoch ? ` · epoch ${key.epoch}` : "";
    return `${key.task_id} · ${key.model} · ${key.condition}${arm}${epoch}`;
  }

  // The seats of the episode: the person's ("you") and the teammates' models.
  function seatsLine(episode, seat) {
    const models = episode && episode.models;
    if (!models) return "";
    if (typeof models === "string") {
      return models === "human" ? "every seat: you (human)" : `every seat: ${models}`;
    }
    return Object.entries(models).map(([agent, model]) =>
      `${agent}: ${agent === seat ? "you (human)" : model}`).join(" · ");
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

  // A half-typed reason or message outlives a reload of this tab (sessionStorage is the
  // tab's own), keyed by the decision it was written for.
  const DRAFTS = ["reason", "message"];
  const draftKey = (of, field) => `cocobench-play:${of.id}:${field}`;

  function restoreDrafts() {
    for (const field of DRAFTS) {
      $(field).value = sessionStorage.getItem(draftKey(decision, field)) || "";
    }
  }

  function forgetDrafts(asked) {
    for (const field of DRAFTS) sessionStorage.removeItem(draftKey(asked, field));
  }

  function drawDecision(state) {
    const next = state.decision;
    $("seats").textContent = seatsLine(state.episode, next && next.seat);
    if (next && decision && next.id === decision.id) {  // keep what is being typed
      updateMenu();
      return;
    }
    decision = next;
    typed = "";
    show("typed", "");
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
      if (ended) show("last-action", "");
      return;
    }
    const step = decision.step_index + 1;
    $("seat-title").textContent = `${decision.seat === "team" ? "The team's planner" :
      decision.seat}: your decision (step ${step})`;
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
    // The result of the seat's last action, as the prompt's history says it: it stays until
    // the next one lands.
    show("last-action", decision.last_action && `Your last action — ${decision.last_action}`);
    $("prompt").textContent = decision.prompt;
    $("prompt-box").hidden = false;
    $("message-field").hidden = !decision.wants_message;
    restoreDrafts();
    drawMenu();
    $("controls").hidden = false;
    say("");
    drawnAt = performance.now();
    updateMenu();
    $("announce").textContent = `${decision.seat === "team" ? "The team" : decision.seat}: ` +
      `your decision, step ${step}, ${decision.menu.length} actions.` +
      (decision.last_action ? ` Your last action: ${decision.last_action}.` : "");
    const first = $("menu").querySelector("button");
    if (first && !first.disabled) first.focus();
  }

  // The menu, its agent named once above that agent's buttons.
  function drawMenu() {
    const drawn = decision;
    const groups = [];
    for (const option of drawn.menu) {
      if (!groups.length || groups[groups.length - 1].agent !== option.agent) {
        groups.push({ agent: option.agent, options: [] });
      }
      groups[groups.length - 1].options.push(option);
    }
    $("menu").dataset.decision = drawn.id;
    $("menu").replaceChildren(...groups.map((group) => {
      const box = element("div", undefined, "menu-group");
      box.setAttribute("role", "group");
      if (group.agent) {
        box.setAttribute("aria-label", `${group.agent}'s actions`);
        box.append(element("h3", group.agent));
      }
      box.append(...group.options.map((option) => {
        const button = element("button", `${option.id}: ${option.label}`);
        button.type = "button";
        button.dataset.id = option.id;
        button.title = option.call;
        button.addEventListener("click", (event) => {
          if (deliberate(event)) choose(drawn, option.id);
        });
        return button;
      }));
      return box;
    }));
  }

  // A click answers only the decision the person saw: not the second click of a double click
  // (detail 2), nor one whose press began before this menu was drawn. Keyboard and assistive
  // technology clicks have detail 0 and no press.
  function deliberate(event) {
    return event.detail === 0 || (event.detail === 1 && pressedAt >= drawnAt);
  }

  function draw(state) {
    drawRun(state);
    drawOutcomes(state.outcomes);
    drawDecision(state);
  }

  // The menu is off while an answer is on its way or taken, and while the run cannot be
  // reached or has refused this tab's token.
  function updateMenu() {
    const enabled = decision !== null && !sending && answered !== decision.id &&
      !unreachable && !tokenDead;
    for (const button of $("menu").querySelectorAll("button")) button.disabled = !enabled;
    $("done").disabled = !enabled;
  }

  // After --resume the run has a new server and token: a tab of an earlier start can only
  // say so.
  function refuseToken() {
    tokenDead = true;
    updateMenu();
    show("problem", "This tab's token is not the run's: it belongs to an earlier start of " +
      "cocobench run (a resumed run has a new token). Open the play address it printed last.");
  }

  // actionId null: DONE (every goal is satisfied), as a model may answer
  async function choose(asked, actionId) {
    if (asked !== decision || sending || answered === asked.id || unreachable || tokenDead) {
      return;
    }
    sending = true;
    updateMenu();
    const body = { decision: asked.id, action_id: actionId, reason: $("reason").value,
      message: asked.wants_message ? $("message").value : "" };
    try {
      const response = await fetch("/play/api/answer", {
        method: "POST", headers: { ...auth, "Content-Type": "application/json" },
        body: JSON.stringify(body) });
      const reply = await response.json();
      if (response.ok) {
        answered = asked.id;
        forgetDrafts(asked);
        const option = asked.menu.find((o) => o.id === actionId);
        say(`Sent ${option ? `${option.id}: ${option.label}` : "DONE"}. ` +
          "Waiting for the next decision…");
      } else if (response.status === 403) {
        refuseToken();
      } else {
        if (response.status === 409) answered = asked.id;  // asked no more
        say(`Not taken: ${reply.error}`);
      }
    } catch (error) {
      say(`Not sent (${error.message}); try again.`);
    } finally {
      sending = false;
      updateMenu();
    }
  }

  function onKey(event) {
    // A held key repeats: only its first press chooses.
    if (event.repeat && (event.key === "Enter" || event.key === " ")) {
      event.preventDefault();
      return;
    }
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
      if (decision.menu.some((option) => option.id === id)) choose(decision, id);
      else say(`${id} is not on the menu.`);
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
        if (response.status === 403) {
          refuseToken();
          return;  // a wrong token stays wrong
        }
        if (!response.ok) throw new Error(state.error);
        unreachable = false;
        show("problem", "");
        version = state.version;
        draw(state);
        if (state.ended !== null) return;
      } catch (error) {
        // The server stops with the run: a page that missed the last word learns it here.
        unreachable = true;
        updateMenu();
        show("problem", "cocobench run is not answering: the run has ended or was stopped " +
          "(its summary is in the terminal; resume a stopped run with cocobench run --out " +
          "RUN --resume, and open the address it prints). Retrying…");
        await pause(2000);
      }
    }
  }

  for (const field of DRAFTS) {
    $(field).addEventListener("input", () => {
      if (decision) sessionStorage.setItem(draftKey(decision, field), $(field).value);
    });
  }
  document.addEventListener("pointerdown", (event) => { pressedAt = event.timeStamp; }, true);
  $("done").addEventListener("click", (event) => {
    if (deliberate(event)) choose(decision, null);
  });
  document.addEventListener("keydown", onKey);
  follow();
})();
