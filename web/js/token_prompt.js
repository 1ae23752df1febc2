// token_prompt.js: the dialog that asks for the access token when the server answers 401
// (index.html's #token-dialog).

const $ = (id) => document.getElementById(id);

/* ask(reason) -> Promise<string|null>. After the user cancels, later asks wait (without a
 * dialog) until reopen() is called, so a reconnect loop does not nag. onState(waiting) tells
 * the status bar that a token is needed. */
export class TokenPrompt {
  constructor({ onState = () => {} } = {}) {
    this.dialog = $('token-dialog');
    this.input = $('token-input');
    this.reason = $('token-reason');
    this.onState = onState;
    this.current = null;
    this.declined = false;
    this.wake = null;
    $('token-cancel').addEventListener('click', () => this.dialog.close('cancel'));
  }

  ask(reason) {
    if (this.current) return this.current;
    this.current = (async () => {
      this.onState(true);
      if (this.declined) await new Promise((r) => { this.wake = r; });
      const t = await this.show(reason);
      this.declined = !t;
      this.onState(!t);
      return t;
    })().finally(() => { this.current = null; });
    return this.current;
  }

  reopen() {
    this.declined = false;
    if (this.wake) { const w = this.wake; this.wake = null; w(); }
  }

  show(reason) {
    return new Promise((resolve) => {
      this.reason.textContent = reason || 'This server needs an access token.';
      this.input.value = '';
      this.dialog.returnValue = '';
      const done = () => {
        this.dialog.removeEventListener('close', done);
        const v = this.input.value.trim();
        resolve(this.dialog.returnValue !== 'cancel' && v ? v : null);
      };
      this.dialog.addEventListener('close', done);
      this.dialog.showModal();
      this.input.focus();
    });
  }
}
