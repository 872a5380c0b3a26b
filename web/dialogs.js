// Modal dialogs on the native <dialog> element: a yes/no confirmation and the POI form.

/** Ask `question`; resolves true only if the operator presses OK. */
export function confirmAction(question, okLabel = 'OK') {
  const dialog = document.getElementById('confirm-dialog');
  dialog.querySelector('.question').textContent = question;
  dialog.querySelector('#confirm-ok').textContent = okLabel;
  dialog.returnValue = '';
  dialog.showModal();
  return new Promise((resolve) => {
    dialog.addEventListener('close', () => resolve(dialog.returnValue === 'ok'), { once: true });
  });
}

/** The POI form; resolves {name, remarks} or null when cancelled. */
export function poiForm({ title, name = '', remarks = '', where = '' }) {
  const dialog = document.getElementById('poi-dialog');
  const form = dialog.querySelector('form');
  dialog.querySelector('.title').textContent = title;
  dialog.querySelector('.where').textContent = where;
  form.elements.name.value = name;
  form.elements.remarks.value = remarks;
  dialog.returnValue = '';
  dialog.showModal();
  form.elements.name.focus();
  form.elements.name.select();
  return new Promise((resolve) => {
    dialog.addEventListener('close', () => {
      const newName = form.elements.name.value.trim();
      resolve(dialog.returnValue === 'ok' && newName
        ? { name: newName, remarks: form.elements.remarks.value.trim() } : null);
    }, { once: true });
  });
}

export const dialogOpen = () => Boolean(document.querySelector('dialog[open]'));
