// Modal dialogs on the native <dialog> element: a yes/no confirmation and the POI form.

/**
 * Ask `question`; resolves true only if the operator confirms: OK pressed, or Enter (the OK
 * button has the focus; Enter on Cancel, reached with Tab, still cancels). Esc cancels, as
 * <dialog> does by itself.
 */
export function confirmAction(question, okLabel = 'OK') {
  const dialog = document.getElementById('confirm-dialog');
  const ok = dialog.querySelector('#confirm-ok');
  dialog.querySelector('.question').textContent = question;
  ok.textContent = okLabel;
  dialog.returnValue = '';
  const enter = (e) => {
    if (e.key !== 'Enter' || e.isComposing || e.target.tagName === 'BUTTON') return;
    e.preventDefault();
    dialog.querySelector('form').requestSubmit(ok);
  };
  dialog.addEventListener('keydown', enter);
  dialog.showModal();
  ok.focus();
  return new Promise((resolve) => {
    dialog.addEventListener('close', () => {
      dialog.removeEventListener('keydown', enter);
      resolve(dialog.returnValue === 'ok');
    }, { once: true });
  });
}

/**
 * Show a form dialog. `validate(name)` returns '' when the name is fine, else the reason: the
 * dialog then stays open with the reason under the field and the operator's input kept.
 * `submit(form)`, when given, is asked on OK and resolves '' once done or why it was refused
 * (the server's answer): a refusal keeps the dialog open the same way.
 */
function formDialog(id, { title, where = '', warning = '', values = {}, validate = () => '', submit = null }) {
  const dialog = document.getElementById(id);
  const form = dialog.querySelector('form');
  const error = dialog.querySelector('.form-error');
  dialog.querySelector('.title').textContent = title;
  dialog.querySelector('.where').textContent = where;
  const warn = dialog.querySelector('.form-warning');
  if (warn) warn.textContent = warning; // shown, not blocking: the server has the last word
  for (const [key, value] of Object.entries(values)) form.elements[key].value = value;
  error.textContent = '';
  dialog.returnValue = '';
  const ok = form.querySelector('button[value="ok"]');
  const refuse = (problem) => {
    error.textContent = problem;
    form.elements.name.focus();
  };
  const check = (e) => {
    if (e.submitter && e.submitter.value !== 'ok') return;
    const problem = validate(form.elements.name.value.trim());
    if (problem || submit) e.preventDefault();
    if (problem) refuse(problem);
    else if (submit && !ok.disabled) {
      ok.disabled = true;
      error.textContent = '';
      submit(form).then((refused) => {
        ok.disabled = false;
        if (refused) refuse(refused);
        else dialog.close('ok');
      });
    }
  };
  // Enter in a field confirms (the form's first submit button is Cancel, which implicit
  // submission would press); Esc cancels, as <dialog> does by itself.
  const enter = (e) => {
    if (e.key !== 'Enter' || e.isComposing || e.target.tagName !== 'INPUT') return;
    e.preventDefault();
    form.requestSubmit(form.querySelector('button[value="ok"]'));
  };
  form.addEventListener('submit', check);
  form.addEventListener('keydown', enter);
  dialog.showModal();
  form.elements.name.focus();
  form.elements.name.select();
  return new Promise((resolve) => {
    dialog.addEventListener('close', () => {
      form.removeEventListener('submit', check);
      form.removeEventListener('keydown', enter);
      const name = form.elements.name.value.trim();
      resolve(dialog.returnValue === 'ok' && name ? form : null);
    }, { once: true });
  });
}

const poiValues = (form) => ({ name: form.elements.name.value.trim(), remarks: form.elements.remarks.value.trim() });

/** The POI form; resolves {name, remarks} or null when cancelled. `submit({name, remarks})`:
 * as formDialog's (the dialog stays open with the server's refusal and the typed name). */
export async function poiForm({ title, name = '', remarks = '', where = '', warning = '', validate, submit }) {
  const form = await formDialog('poi-dialog', { title, where, warning, values: { name, remarks }, validate,
    submit: submit && ((f) => submit(poiValues(f))) });
  return form && poiValues(form);
}

/** Ask for a name; resolves it, or null when cancelled. */
export async function nameForm({ title, name = '', where = '', validate }) {
  const form = await formDialog('name-dialog', { title, where, values: { name }, validate });
  return form && form.elements.name.value.trim();
}

export const dialogOpen = () => Boolean(document.querySelector('dialog[open]'));
