// The report page: reads the two JSON blocks rtuscope embedded (the statistics exactly as
// `rtuscope stats --jsonl` prints them, and the series over time) and draws them with
// uPlot. Every chart marks itself drawn on <body data-drawn>, for the tests and for
// anyone checking a page that looks empty.
"use strict";
(function () {
  const statsLines = document.getElementById("stats-jsonl").textContent
    .split("\n").filter(function (line) { return line.trim() !== ""; })
    .map(function (line) { return JSON.parse(line); });
  const bus = statsLines[0].bus;
  const rows = statsLines.slice(1);
  const data = JSON.parse(document.getElementById("series-json").textContent);

  const palette = ["#1f77b4", "#d62728", "#ff7f0e", "#9467bd", "#2ca02c", "#8c564b", "#e377c2", "#17becf"];
  const maxSlaveCards = 32;
  const chartWidth = Math.max(360, Math.min(1160, document.body.clientWidth - 40));

  // --- helpers ------------------------------------------------------------------------
  function el(tag, attrs, children) {
    const e = document.createElement(tag);
    if (attrs) {
      for (const k of Object.keys(attrs)) {
        if (k === "text") e.textContent = attrs[k];
        else if (k === "cls") e.className = attrs[k];
        else e.setAttribute(k, attrs[k]);
      }
    }
    for (const c of children || []) e.appendChild(typeof c === "string" ? document.createTextNode(c) : c);
    return e;
  }
  function section(id) { return document.getElementById(id); }
  function num(x, digits) {
    if (x === null || x === undefined || Number.isNaN(x)) return "-";
    return typeof digits === "number" ? x.toFixed(digits) : String(x);
  }
  function pct(part, whole) { return whole > 0 ? (100 * part / whole) : null; }
  function duration(s) {
    if (s === null || s === undefined) return "-";
    if (s < 120) return s.toFixed(3) + " s";
    const h = Math.floor(s / 3600), m = Math.floor((s % 3600) / 60), sec = Math.round(s % 60);
    return (h > 0 ? h + " h " : "") + m + " min " + sec + " s";
  }
  function timeText(t) {
    if (t === null || t === undefined) return "-";
    if (data.clock === "none") return t.toFixed(3) + " s";
    const d = new Date(t * 1000);
    const pad = function (n, w) { return String(n).padStart(w || 2, "0"); };
    if (data.clock === "utc") {
      return d.toISOString().replace("T", " ").replace("Z", "");
    }
    return d.getFullYear() + "-" + pad(d.getMonth() + 1) + "-" + pad(d.getDate()) + " " +
      pad(d.getHours()) + ":" + pad(d.getMinutes()) + ":" + pad(d.getSeconds()) + "." + pad(d.getMilliseconds(), 3);
  }

  // --- charts -------------------------------------------------------------------------
  let created = 0;
  let drawn = 0;
  let allCreated = false;
  const timeCharts = [];
  let focusTime = null;
  let syncing = false;

  function markDrawn(u) {
    if (!u.rtuscopeDrawn) {
      u.rtuscopeDrawn = true;
      drawn += 1;
      document.body.setAttribute("data-drawn", String(drawn));
      checkAllDrawn();
    }
  }
  function checkAllDrawn() {
    if (allCreated && drawn === created && document.body.getAttribute("data-all-drawn") !== "yes") {
      document.body.setAttribute("data-all-drawn", "yes");
      // Milliseconds from the page's start until its last chart drew (docs/performance.md).
      document.body.setAttribute("data-drawn-ms", String(Math.round(performance.now())));
    }
  }
  function syncScale(u, key) {
    if (key !== "x" || syncing) return;
    syncing = true;
    for (const other of timeCharts) {
      if (other !== u) other.setScale("x", { min: u.scales.x.min, max: u.scales.x.max });
    }
    syncing = false;
  }
  function drawFocus(u) {
    if (focusTime === null) return;
    const x = u.valToPos(focusTime, "x", true);
    if (x < u.bbox.left || x > u.bbox.left + u.bbox.width) return;
    const ctx = u.ctx;
    ctx.save();
    ctx.strokeStyle = "#c0392b";
    ctx.lineWidth = 2;
    ctx.beginPath();
    ctx.moveTo(x, u.bbox.top);
    ctx.lineTo(x, u.bbox.top + u.bbox.height);
    ctx.stroke();
    ctx.restore();
  }
  function makeChart(opts, chartData, parent) {
    opts.hooks = opts.hooks || {};
    opts.hooks.draw = (opts.hooks.draw || []).concat([markDrawn]);
    created += 1;
    document.body.setAttribute("data-charts", String(created));
    const holder = el("div", { cls: "chart" });
    parent.appendChild(holder);
    return new uPlot(opts, chartData, holder);
  }

  const xs = [];
  for (let i = 0; i < data.buckets; i++) xs.push(data.t0 + i * data.dt);

  function timeChart(parent, title, yLabel, series, columns, extraDraw, height) {
    const opts = {
      title: title,
      width: chartWidth,
      height: height || 220,
      scales: { x: { time: data.clock !== "none" }, "%": { range: [0, 100] } },
      cursor: { sync: { key: "rtuscope" } },
      series: [{ label: "time", value: function (u, v) { return v === null ? "-" : timeText(v); } }].concat(series),
      axes: [{}, { label: yLabel, size: 60 }].concat(series.some(function (s) { return s.scale === "%"; })
        ? [{ scale: "%", side: 1, label: "answered %", size: 50, grid: { show: false } }] : []),
      hooks: { setScale: [syncScale], draw: [drawFocus].concat(extraDraw ? [extraDraw] : []) },
    };
    if (data.clock === "utc") opts.tzDate = function (ts) { return uPlot.tzDate(new Date(ts * 1e3), "Etc/UTC"); };
    const u = makeChart(opts, [xs].concat(columns), parent);
    timeCharts.push(u);
    return u;
  }
  function line(label, color, extra) {
    // Polled figures come a point every few buckets: the line joins them across the
    // empty buckets between.
    const s = { label: label, stroke: color, width: 1.5, spanGaps: true };
    return Object.assign(s, extra || {});
  }
  function zoomTo(t) {
    focusTime = t;
    const span = Math.max(20 * data.dt, 10);
    for (const u of timeCharts) u.setScale("x", { min: t - span, max: t + span });
    section("timeline").scrollIntoView();
  }
  function timeLink(t) {
    if (t === null || t === undefined || data.buckets === 0) return el("span", { text: timeText(t) });
    const a = el("a", { cls: "time", href: "#timeline", text: timeText(t) });
    a.addEventListener("click", function (event) { event.preventDefault(); zoomTo(t); });
    return a;
  }

  // --- the bus at a glance ------------------------------------------------------------
  const all = bus.all;
  const perSlave = new Map();
  for (const r of rows) {
    if (!perSlave.has(r.slave)) perSlave.set(r.slave, []);
    perSlave.get(r.slave).push(r);
  }
  function slaveSum(slave, key) {
    return (perSlave.get(slave) || []).reduce(function (s, r) { return s + r[key]; }, 0);
  }
  const errorsTotal = all.crc_errors + bus.invalid + bus.noise_runs + all.no_answer + all.exceptions;
  section("subtitle").textContent = bus.source + " (" + bus.input_format + " input), " + bus.line +
    (bus.devices ? "; devices: " + bus.devices : "") + "; rtuscope " + data.version;
  const figures = [
    ["duration", bus.timed ? duration(bus.duration_s) : "no timing", false],
    ["line", bus.line + (bus.baud_origin === "input" ? "" : " (" + bus.baud_origin + ")"), false],
    ["frames", bus.frames + " (" + bus.bytes + " bytes)", false],
    ["utilisation", bus.utilisation_pct === null ? "-" : num(bus.utilisation_pct, 1) + " %", bus.utilisation_pct > 60],
    ["errors", String(errorsTotal), errorsTotal > 0],
    ["bad CRC", String(all.crc_errors), all.crc_errors > 0],
    ["invalid frames", String(bus.invalid), bus.invalid > 0],
    ["noise", bus.noise_bytes + " bytes in " + bus.noise_runs + " runs", bus.noise_runs > 0],
    ["exceptions", String(all.exceptions), all.exceptions > 0],
    ["unanswered requests", all.no_answer + " of " + all.requests, all.no_answer > 0],
    ["poll cycle", bus.poll && bus.poll.cycle_median_ms !== null ? num(bus.poll.cycle_median_ms, 2) + " ms median" : "-", false],
    ["turnaround p50 / p99", num(all.turnaround_p50_ms, 2) + " / " + num(all.turnaround_p99_ms, 2) + " ms", false],
  ];
  const glance = section("glance");
  glance.appendChild(el("div", { cls: "figures" }, figures.map(function (f) {
    return el("div", { cls: "figure" + (f[2] ? " bad" : "") }, [f[0], el("b", { text: f[1] })]);
  })));

  // Anomalies, the worst first: each a score, a sentence and, where it has one, a time.
  const anomalies = [];
  for (const [slave, slaveRows] of perSlave) {
    const requests = slaveSum(slave, "requests");
    const noAnswer = slaveSum(slave, "no_answer");
    const exceptions = slaveSum(slave, "exceptions");
    const crc = slaveSum(slave, "crc_errors");
    if (noAnswer > 0) {
      anomalies.push({ score: 300 * noAnswer / Math.max(1, requests) + Math.log10(1 + noAnswer),
        text: "slave " + slave + ": " + noAnswer + " of " + requests + " requests unanswered (" + num(pct(noAnswer, requests), 1) + " %)" });
    }
    if (exceptions > 0) {
      anomalies.push({ score: 200 * exceptions / Math.max(1, requests) + Math.log10(1 + exceptions),
        text: "slave " + slave + ": " + exceptions + " exceptions to " + requests + " requests" });
    }
    if (crc > 0) {
      anomalies.push({ score: 10 + Math.log10(1 + crc) * 10, text: "slave " + slave + ": " + crc + " frames with a bad CRC" });
    }
    for (const r of slaveRows) {
      if (r.turnaround_p50_ms > 0 && r.turnaround_p99_ms > 5 && r.turnaround_p99_ms > 4 * r.turnaround_p50_ms) {
        const ratio = r.turnaround_p99_ms / r.turnaround_p50_ms;
        anomalies.push({ score: Math.min(100, 5 * ratio),
          text: "slave " + slave + " function " + r.function + ": turnaround p99 " + num(r.turnaround_p99_ms, 1) +
            " ms is " + num(ratio, 1) + " times the median " + num(r.turnaround_p50_ms, 1) + " ms" });
      }
    }
  }
  if (bus.noise_bytes > 0) {
    anomalies.push({ score: 10 + 200 * bus.noise_bytes / Math.max(1, bus.bytes),
      text: bus.noise_bytes + " noise bytes (" + num(pct(bus.noise_bytes, bus.bytes), 2) + " % of the line)" });
  }
  if (bus.utilisation_pct > 60) {
    anomalies.push({ score: bus.utilisation_pct, text: "the line is busy " + num(bus.utilisation_pct, 1) + " % of the time" });
  }
  if (bus.timed && bus.utilisation_pct === null && bus.bytes > 0) {
    anomalies.push({ score: 90, text: "the bytes take longer than the capture lasts at " + bus.line + ": the baud rate is wrong" });
  }
  // A slave that slows for a while (every evening, say): the median of each tenth of the
  // timeline's turnaround points (one slow answer moves no median), the slowest tenth
  // against the fastest.
  for (const s of data.slaves) {
    const parts = [];
    const tenth = Math.max(1, Math.ceil(s.turnaround_mean_ms.length / 10));
    for (let from = 0; from < s.turnaround_mean_ms.length; from += tenth) {
      const points = [];
      for (let i = from; i < Math.min(from + tenth, s.turnaround_mean_ms.length); i++) {
        if (s.turnaround_mean_ms[i] !== null) points.push(s.turnaround_mean_ms[i]);
      }
      points.sort(function (a, b) { return a - b; });
      if (points.length >= 5) parts.push({ mean: points[Math.floor(points.length / 2)], t: xs[from] });
    }
    if (parts.length < 3) continue;
    const fastest = parts.reduce(function (a, b) { return b.mean < a.mean ? b : a; });
    const slowest = parts.reduce(function (a, b) { return b.mean > a.mean ? b : a; });
    if (slowest.mean > 1.5 * fastest.mean && slowest.mean - fastest.mean > 2) {
      anomalies.push({ score: Math.min(80, 20 * slowest.mean / Math.max(fastest.mean, 0.001)), t: slowest.t,
        text: "slave " + s.slave + " slows down: median turnaround " + num(slowest.mean, 1) + " ms against " +
          num(fastest.mean, 1) + " ms at its fastest; the slowest tenth of the capture from" });
    }
  }
  const errorTotals = xs.map(function (_, i) {
    return data.bus.errors.reduce(function (sum, kind) { return sum + kind.counts[i]; }, 0);
  });
  if (errorTotals.length > 1) {
    let peak = 0, peakAt = 0, total = 0;
    errorTotals.forEach(function (n, i) { total += n; if (n > peak) { peak = n; peakAt = i; } });
    const mean = total / errorTotals.length;
    if (peak >= 3 && peak > 5 * mean) {
      anomalies.push({ score: 20 + Math.min(60, peak / Math.max(mean, 0.01)), t: xs[peakAt],
        text: "errors cluster: " + peak + " in " + num(data.dt, 1) + " s, " + num(mean, 2) + " on average; at" });
    }
  }
  for (const v of data.values) {
    if (v.max_step !== null && v.mean_step !== null && v.max_step > 10 * v.mean_step && v.max_step > 0) {
      anomalies.push({ score: 10 + Math.min(60, v.max_step / Math.max(v.mean_step, 1e-9)), t: v.max_step_t,
        text: "slave " + v.slave + " " + (v.name || "0x" + v.address.toString(16)) + " jumps by " + num(v.max_step, 3) +
          (v.unit ? " " + v.unit : "") + " (mean step " + num(v.mean_step, 3) + ") at" });
    }
  }
  for (const remark of data.remarks) anomalies.push({ score: 50, text: remark });
  anomalies.sort(function (a, b) { return b.score - a.score; });
  glance.appendChild(el("h3", { text: anomalies.length ? "Anomalies, the worst first" : "No anomaly found" }));
  if (anomalies.length) {
    glance.appendChild(el("ol", {}, anomalies.slice(0, 15).map(function (a) {
      const item = el("li", { cls: "anomaly" + (a.score >= 50 ? " high" : "") }, [a.text]);
      if (a.t !== undefined && a.t !== null) item.append(" ", timeLink(a.t));
      return item;
    })));
  }

  // --- timeline -----------------------------------------------------------------------
  const timeline = section("timeline");
  if (data.buckets === 0) {
    timeline.appendChild(el("p", { text: "No timing in the input: nothing to draw over time." }));
  } else {
    timeline.appendChild(el("p", { cls: "muted", text: "Each point is " + num(data.dt, 3) + " s of the line" +
      (data.dt > 0.1 ? " (the capture is long: its points are merged to keep the page small)" : "") + "." }));
    const perSecond = function (counts) { return counts.map(function (n) { return n / data.dt; }); };
    timeChart(timeline, "frames per second", "frames/s", [line("frames/s", palette[0], { fill: "rgba(31,119,180,0.1)" })],
      [perSecond(data.bus.frames)]);
    timeChart(timeline, "errors per second by kind", "errors/s",
      data.bus.errors.map(function (k, i) { return line(k.label, palette[(i + 1) % palette.length]); }),
      data.bus.errors.map(function (k) { return perSecond(k.counts); }));
  }

  // --- slaves -------------------------------------------------------------------------
  const slavesSection = section("slaves");
  const slaves = data.slaves.slice().sort(function (a, b) { return b.frames - a.frames; });
  if (slaves.length > maxSlaveCards) {
    slavesSection.appendChild(el("p", { cls: "muted", text: "The " + maxSlaveCards + " busiest of " + slaves.length + " slaves." }));
  }
  const edge = function (i) { return i === 0 ? 0 : 0.01 * Math.pow(10, (i - 1) / 10); };
  for (const s of slaves.slice(0, maxSlaveCards)) {
    const card = el("div", { cls: "slave", id: "slave-" + s.slave });
    card.appendChild(el("h3", { text: "Slave " + s.slave }));
    const slaveRows = perSlave.get(s.slave) || [];
    const table = el("table", {}, [el("tr", {}, ["fc", "requests", "answered %", "exceptions", "no answer", "bad CRC",
      "p50 ms", "p95 ms", "p99 ms", "max ms", "cycle ms"].map(function (h) { return el("th", { text: h }); }))]);
    for (const r of slaveRows) {
      table.appendChild(el("tr", {}, [r.function, r.requests, num(pct(r.answers + r.exceptions, r.requests), 1), r.exceptions,
        r.no_answer, r.crc_errors, num(r.turnaround_p50_ms), num(r.turnaround_p95_ms), num(r.turnaround_p99_ms),
        num(r.turnaround_max_ms), num(r.cycle_median_ms)].map(function (c) { return el("td", { text: String(c) }); })));
    }
    card.appendChild(table);
    const codes = new Map();
    for (const r of slaveRows) {
      for (const code of Object.keys(r.exception_codes)) {
        codes.set(code, (codes.get(code) || 0) + r.exception_codes[code]);
      }
    }
    if (codes.size) {
      card.appendChild(el("table", {}, [el("tr", {}, [el("th", { text: "exception" }), el("th", { cls: "l", text: "name" }), el("th", { text: "count" })])]
        .concat(Array.from(codes).map(function (c) {
          return el("tr", {}, [el("td", { text: "0x" + Number(c[0]).toString(16).padStart(2, "0").toUpperCase() }),
            el("td", { cls: "l", text: data.exception_names[c[0]] || "" }), el("td", { text: String(c[1]) })]);
        }))));
    }
    const charts = el("div", { cls: "charts" });
    card.appendChild(charts);
    let first = -1, last = -1;
    s.histogram.forEach(function (n, i) { if (n > 0) { if (first < 0) first = i; last = i; } });
    if (first >= 0) {
      const bins = [], counts = [];
      for (let i = Math.max(0, first - 1); i <= Math.min(s.histogram.length - 1, last + 1); i++) { bins.push(i); counts.push(s.histogram[i]); }
      makeChart({
        title: "turnaround histogram (ms, log bins)",
        width: Math.min(chartWidth, 520), height: 200,
        scales: { x: { time: false, range: [bins[0] - 0.5, bins[bins.length - 1] + 0.5] } },
        series: [{ label: "from ms", value: function (u, v) { return v === null ? "-" : num(edge(v), 3); } },
          { label: "answers", stroke: palette[0], fill: "rgba(31,119,180,0.5)", paths: uPlot.paths.bars({ size: [0.9, 60] }), points: { show: false } }],
        axes: [{ values: function (u, splits) { return splits.map(function (v) { return Number.isInteger(v) ? num(edge(v), edge(v) < 1 ? 2 : 0) : ""; }); } },
          { label: "answers", size: 60 }],
      }, [bins, counts], charts);
    }
    if (data.buckets > 0) {
      const u = timeChart(charts, "turnaround and poll cycle over time (ms)", "ms",
        [line("turnaround mean", palette[0]), line("turnaround max", palette[1], { width: 1, dash: [4, 3] }),
          line("poll cycle mean", palette[4]), line("answered %", palette[3], { scale: "%" })],
        [s.turnaround_mean_ms, s.turnaround_max_ms, s.cycle_mean_ms, s.answered_pct], null, 200);
    }
    slavesSection.appendChild(card);
  }
  if (!slaves.length) slavesSection.appendChild(el("p", { text: "No slave answered or was asked." }));

  // --- register values ----------------------------------------------------------------
  const valuesSection = section("values");
  if (!data.values.length) {
    valuesSection.appendChild(el("p", { text: "No register values: rtuscope decodes them with a profile (--device ADDR=PROFILE, --bus FILE or --as)." }));
  } else if (data.buckets > 0) {
    if (data.values_left_out) {
      valuesSection.appendChild(el("p", { cls: "muted", text: "The first " + data.values.length + " registers met; " + data.values_left_out + " more values of other registers are not charted." }));
    }
    for (const v of data.values) {
      const title = "slave " + v.slave + " " + v.profile + ": " + (v.name || "register") + " (0x" +
        v.address.toString(16).padStart(4, "0").toUpperCase() + ")" + (v.unit ? " in " + v.unit : "") +
        (v.write_count ? ", " + v.write_count + " writes marked" : "");
      const writes = v.writes;
      const drawWrites = function (u) {
        const ctx = u.ctx;
        ctx.save();
        ctx.strokeStyle = "#e67e22";
        ctx.fillStyle = "#e67e22";
        ctx.setLineDash([5, 3]);
        ctx.font = "11px sans-serif";
        for (const w of writes) {
          const x = u.valToPos(w[0], "x", true);
          if (x < u.bbox.left || x > u.bbox.left + u.bbox.width) continue;
          ctx.beginPath();
          ctx.moveTo(x, u.bbox.top);
          ctx.lineTo(x, u.bbox.top + u.bbox.height);
          ctx.stroke();
          ctx.fillText("write " + w[1], x + 3, u.bbox.top + 12);
        }
        ctx.restore();
      };
      timeChart(valuesSection, title, v.unit || "value",
        [line("mean", palette[0]), line("min", "rgba(31,119,180,0.45)", { width: 1 }), line("max", "rgba(214,39,40,0.45)", { width: 1 })],
        [v.mean, v.min, v.max], drawWrites, 200);
    }
  }

  // --- flagged records ----------------------------------------------------------------
  const flaggedSection = section("flagged");
  const flagged = data.flagged;
  flaggedSection.appendChild(el("p", { cls: "muted", text: flagged.total + " records have notes" +
    (flagged.total > flagged.records.length ? "; the first " + flagged.records.length + " are listed (--flagged N lists more)" : "") + "." }));
  if (flagged.records.length) {
    const table = el("table", {}, [el("tr", {}, ["record", "time", "slave", "fc", "kind", "notes"].map(function (h, i) {
      return el("th", { cls: i >= 4 ? "l" : "", text: h });
    }))]);
    for (const f of flagged.records) {
      table.appendChild(el("tr", { id: "record-" + f.number }, [
        el("td", { text: String(f.number) }), el("td", {}, [timeLink(f.t)]), el("td", { text: String(f.slave) }),
        el("td", { text: f.function.toString(16).padStart(2, "0").toUpperCase() }), el("td", { cls: "l", text: f.kind }),
        el("td", { cls: "l", text: f.notes.map(function (n) { return n[0] + ": " + n[1]; }).join("; ") })]));
    }
    flaggedSection.appendChild(table);
  }

  allCreated = true;
  checkAllDrawn();
})();
