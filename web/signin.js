// Signing in to a server started with --authenticate: the token is kept in sessionStorage (it
// survives a reload, for this tab's life only), sent as ?token= on the WebSocket URL and on
// the console's HTTP requests (downloads). After connecting, /hitrobot/whoami says the token's
// name, role and permissions: the role badge shows them, and each control the role lacks is
// disabled with the reason on hover. Signing out forgets the token and reloads.
import { SERVICES } from './names.js';
import { el } from './util.js';

const KEY = 'hitrobot.token';

export function savedToken() {
  return sessionStorage.getItem(KEY) || '';
}

/** ``url`` with the tab's token as ?token= (unchanged without one). */
export function withToken(url) {
  const token = savedToken();
  if (!token) return url;
  return `${url}${url.includes('?') ? '&' : '?'}token=${encodeURIComponent(token)}`;
}

// What each control needs (the server's permission names, protocol/access.py).
const NEEDS = [
  ['[data-tool=goal]', 'goals'], ['[data-tool=pose]', 'localize'], ['[data-tool=poi]', 'pois'],
  ['#cancel-goal', 'cancel'], ['#go-home', 'moves'], ['#stop-motion', 'moves'],
  ['#relocalize', 'localize'], ['#pad button', 'drive'],
  ['#patrol-clear', 'patrols'], ['#patrol-start', 'patrols'], ['#patrol-stop', 'patrols'],
  ['#patrol-resume', 'patrols'], ['#shell button', 'shell'],
  ['[data-tool=wall]', 'walls'], ['[data-tool=track]', 'walls'], ['[data-tool=area]', 'walls'],
  ['[data-tool=erase]', 'walls'], ['[data-tool=unline]', 'walls'], ['#clear-walls', 'walls'],
  ['#clear-tracks', 'walls'], ['#map-save-as', 'maps'], ['#publish-send', 'publish'],
];

/** The sign-in box, shown over the page; resolves never (a sign-in reloads the page). */
export function showSignIn(reason = '') {
  const input = el('input', { type: 'password', id: 'signin-token', autocomplete: 'off',
    placeholder: 'token (hitrobot-server token add …)', 'aria-label': 'token' });
  const form = el('form', { id: 'signin', class: 'signin' },
    el('h2', {}, 'Sign in'),
    el('p', { class: 'why' }, reason || 'This server asks for a token.'),
    input, el('button', { type: 'submit', id: 'signin-ok' }, 'Sign in'));
  form.addEventListener('submit', (e) => {
    e.preventDefault();
    sessionStorage.setItem(KEY, input.value.trim());
    location.reload();
  });
  document.body.append(form);
  document.body.classList.add('signing-in');
  input.focus();
}

/** Before connecting: does the server take us (no token needed, or the tab's token good)?
 * /healthz answers 401 only for a missing or refused token (403: the role may not read it). */
export async function signedIn() {
  let response;
  try {
    response = await fetch(withToken('healthz'), { cache: 'no-store' });
  } catch (err) {
    return true; // unreachable: the connection pill says so
  }
  if (response.status !== 401) return true;
  const why = (await response.text()).trim();
  const had = savedToken();
  sessionStorage.removeItem(KEY);
  showSignIn(had ? `Not accepted: ${why}` : why);
  return false;
}

function signOut() {
  sessionStorage.removeItem(KEY);
  location.reload();
}

/** The role badge and the controls the role lacks, from /hitrobot/whoami. */
export function followRole(stores) {
  const badge = el('span', { class: 'pill', id: 'role', 'data-role': 'unknown', hidden: '',
    title: 'Who this console is signed in as' }, el('b', {}, 'role'), ' ',
  el('span', { class: 'value' }, '…'));
  document.querySelector('.topbar .pills').append(badge);
  let who = null;
  const apply = () => { if (who) disableLacking(who); };
  stores.ros.on('connection', async () => {
    const { reply: answer } = await stores.call(SERVICES.whoami);
    if (!answer) return;
    who = JSON.parse(answer.message);
    badge.hidden = !who.authenticate; // without --authenticate everyone is admin: no badge
    badge.dataset.role = who.role;
    badge.querySelector('.value').textContent = who.name ? `${who.name} · ${who.role}` : who.role;
    if (who.authenticate && !badge.querySelector('button')) {
      const out = el('button', { type: 'button', id: 'signout', class: 'small', title: 'Forget the token' }, 'sign out');
      out.addEventListener('click', signOut);
      badge.append(' ', out);
    }
    apply();
  });
  // the page re-enables its tools when the bridge comes back: the role's limits after it
  window.addEventListener('bridge', () => setTimeout(apply, 0));
  return { get who() { return who; } };
}

function disableLacking(who) {
  const have = new Set(who.permissions);
  for (const [selector, permission] of NEEDS) {
    for (const control of document.querySelectorAll(selector)) {
      if (have.has(permission)) {
        if (control.dataset.lacks) {
          control.disabled = false;
          delete control.dataset.lacks;
        }
        continue;
      }
      control.disabled = true;
      control.dataset.lacks = permission;
      control.title = `Your role '${who.role}' lacks the permission '${permission}'`;
    }
  }
}
