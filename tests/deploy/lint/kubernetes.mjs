// Validates Kubernetes manifests (multi-document YAML) against the Kubernetes API schemas.
// Usage: node kubernetes.mjs FILE.yaml...   Exit 0: every document valid; 1: any problem (each
// is printed as FILE: document N (Kind/name): problem).
//
// Two checks, because kubectl apply (strict field validation, the default since Kubernetes 1.27)
// refuses both kinds of mistake:
//   1. kubernetes-models validates each document with the JSON schemas generated from the
//      official Kubernetes OpenAPI document: types, required fields, enums, formats (quantities,
//      ports, names). It is typed, maintained and needs no cluster or network (Go validators
//      such as kubeconform are not on npm; Debian packages none).
//   2. Those schemas allow properties they do not list, so a misspelt field (imagePullPolcy)
//      would pass. The same package's TypeScript declarations list every field: each document
//      is type-checked as an object literal of its kind's interface, and TypeScript's excess
//      property check reports any field the API does not have.
// Only kinds that kubernetes-models knows are accepted (no custom resources here).
import { readFileSync } from "node:fs";
import { createRequire } from "node:module";
import path from "node:path";
import { fileURLToPath } from "node:url";
import { parseAllDocuments } from "yaml";
import ts from "typescript";

const here = path.dirname(fileURLToPath(import.meta.url));
const require = createRequire(import.meta.url);

// "apps/v1" + "Deployment" -> the kubernetes-models module of that kind ("v1" is the core group).
function modelModule(apiVersion, kind) {
  if (typeof apiVersion !== "string" || typeof kind !== "string") return null;
  if (!/^([a-z0-9.-]+\/)?v[0-9a-z]+$/.test(apiVersion) || !/^[A-Z][A-Za-z0-9]*$/.test(kind)) return null;
  return `kubernetes-models/${apiVersion}/${kind}`;
}

const problems = [];
const typed = []; // {label, module, kind, json} for the TypeScript check

for (const file of process.argv.slice(2)) {
  const docs = parseAllDocuments(readFileSync(file, "utf8"), { uniqueKeys: true, prettyErrors: true });
  docs.forEach((doc, i) => {
    const where = `${file}: document ${i + 1}`;
    for (const e of [...doc.errors, ...doc.warnings]) problems.push(`${where}: YAML: ${e.message}`);
    if (doc.errors.length) return;
    const obj = doc.toJS();
    if (obj === null || obj === undefined) return; // an empty document (a trailing ---)
    const label = `${where} (${obj.kind}/${obj.metadata && obj.metadata.name})`;
    const mod = modelModule(obj.apiVersion, obj.kind);
    let Model = null;
    try {
      Model = mod && require(mod)[obj.kind];
    } catch {
      Model = null;
    }
    if (!Model) {
      problems.push(`${label}: unknown apiVersion/kind ${obj.apiVersion}/${obj.kind}`);
      return;
    }
    try {
      new Model(obj).validate();
    } catch (e) {
      problems.push(`${label}: ${e.message}`);
    }
    typed.push({ label, module: mod, kind: obj.kind, json: obj });
  });
}

// The TypeScript check: one virtual source file beside this script (so that node_modules
// resolves), one typed constant per document; each diagnostic is traced back to its document.
if (typed.length) {
  const virtual = path.join(here, "__manifests__.ts");
  let text = "";
  const starts = []; // the first line of each document's constant
  typed.forEach((d, i) => {
    starts.push(text.split("\n").length - 1);
    text += `import type { I${d.kind} as T${i} } from "${d.module}";\n`;
    text += `export const doc${i}: T${i} = ${JSON.stringify(d.json, null, 2)};\n`;
  });
  const options = { strict: true, noEmit: true, skipLibCheck: true, types: [],
                    module: ts.ModuleKind.CommonJS, moduleResolution: ts.ModuleResolutionKind.Node10,
                    target: ts.ScriptTarget.ES2020 };
  const host = ts.createCompilerHost(options);
  const getSourceFile = host.getSourceFile;
  host.getSourceFile = (name, lang, ...rest) =>
    path.resolve(name) === virtual ? ts.createSourceFile(name, text, lang) : getSourceFile(name, lang, ...rest);
  const fileExists = host.fileExists;
  host.fileExists = (name) => path.resolve(name) === virtual || fileExists(name);
  const program = ts.createProgram([virtual], options, host);
  for (const diag of ts.getPreEmitDiagnostics(program)) {
    const msg = ts.flattenDiagnosticMessageText(diag.messageText, "\n  ");
    if (!diag.file || path.resolve(diag.file.fileName) !== virtual) {
      problems.push(`TypeScript: ${msg}`);
      continue;
    }
    const { line } = diag.file.getLineAndCharacterOfPosition(diag.start);
    let k = 0;
    while (k + 1 < starts.length && starts[k + 1] <= line) k++;
    const src = text.split("\n")[line].trim();
    problems.push(`${typed[k].label}: ${msg} (at ${src})`);
  }
}

for (const p of problems) console.error(p);
if (problems.length) {
  console.error(`${problems.length} problem(s)`);
  process.exit(1);
}
console.log(`${typed.length} document(s) valid`);
