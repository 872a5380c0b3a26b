// Where the robot's state came from, said once in the Messages panel when the page first hears
// from the server: "state restored from …" (with what came back) or "started fresh in …"; and,
// for as long as it lasts, a red pill in the top bar when the state folder cannot be written:
// "state is not being saved: disk full" (changes are then refused, not acknowledged). The
// server reports both in the /Bridge/State entry of /diagnostics_agg (its `saving` value).
import { log } from './log.js';
import { DIAGNOSTICS, TOPICS } from './names.js';
import { el } from './util.js';

function savingPill() {
  const pill = el('span', { class: 'pill', id: 'state-saving', dataset: { state: 'broken' }, role: 'alert',
    title: 'The robot\'s state folder (/Bridge/State in /diagnostics_agg)' }, el('i'), el('span', { class: 'value' }));
  pill.style.display = 'none';  // not `hidden`: the pills' own display would override it
  document.querySelector('.topbar .pills').append(pill);
  return pill;
}

/**
 * The server's start-up line as this page says it: what came back at the start, without the
 * values of then that the page shows live now (the battery, the pose: "battery 78%" beside a
 * bar at 77 % reads as a contradiction), and in a replay as the recorded server's line.
 */
export function startLine(message, restored) {
  const what = (restored || '').replace(/robot pose \([^)]*\)/, "the robot's pose")
    .replace(/battery \d+(?:\.\d+)?\s*%/, 'its battery level');
  let text = what && what !== 'nothing' ? `${message} at the server's start: ${what}` : message;
  if (document.body.classList.contains('replaying')) text = `recorded: ${text} (the replayed server's start, not this one's)`;
  return text;
}

export function showStateOnce(stores) {
  const topic = stores.topic(TOPICS.diagnostics);
  const pill = savingPill();
  let told = false;
  let failing = '';
  topic.subscribe((msg) => {
    const item = msg.status.find((s) => s.name === DIAGNOSTICS.bridgeState);
    if (!item) return;
    const value = (key) => (item.values.find((v) => v.key === key) || {}).value;
    if (!told) {
      told = true;
      log('info', startLine(item.message, value('restored')));  // no toast: nothing went wrong
    }
    const saving = value('saving') || 'yes';
    const now = saving.startsWith('no: ') ? saving.slice(4) : '';
    if (now === failing) return;
    failing = now;
    pill.style.display = now ? '' : 'none';
    pill.querySelector('.value').textContent = now ? `state is not being saved: ${now}` : '';
    if (now) log('error', `state is not being saved: ${now}`);
    else log('info', 'state is being saved again');
  });
}
