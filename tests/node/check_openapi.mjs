// The OpenAPI document and the JSON bodies the service sends, checked with real validators.
//   node tests/node/check_openapi.mjs lint OPENAPI.json
//     @apidevtools/swagger-parser validates the document (OpenAPI 3.0 schema, references), then Ajv compiles every
//     component schema in strict mode (which refuses, e.g., `nullable` without `type`).
//   node tests/node/check_openapi.mjs bodies OPENAPI.json EXCHANGES.jsonl
//     each line {method, path, status, body}: the response schema that the document gives for that path template,
//     method and status (application/json) must accept the body.
// Prints one line per problem; exits 1 when there is one, 2 on misuse.
import { readFile } from 'node:fs/promises';
import SwaggerParser from '@apidevtools/swagger-parser';
import Ajv from 'ajv';
import addFormats from 'ajv-formats';

const [mode, documentPath, exchangesPath] = process.argv.slice(2);
if (!['lint', 'bodies'].includes(mode) || !documentPath || (mode === 'bodies' && !exchangesPath)) {
  console.error('usage: check_openapi.mjs lint OPENAPI.json | bodies OPENAPI.json EXCHANGES.jsonl');
  process.exit(2);
}
const document = JSON.parse(await readFile(documentPath, 'utf8'));

/// Ajv over the document's component schemas, reachable as `schemas#/$defs/<Name>`.
function schemaValidator() {
  const ajv = new Ajv({ strict: true, allErrors: true });
  addFormats(ajv);
  ajv.addVocabulary(['example']);  // OpenAPI's annotation
  ajv.addFormat('binary', true);    // OpenAPI's format of raw bytes
  const defs = JSON.parse(JSON.stringify(document.components.schemas).replaceAll('#/components/schemas/', 'schemas#/$defs/'));
  ajv.addSchema({ $id: 'schemas', $defs: defs });
  return ajv;
}

const problems = [];
if (mode === 'lint') {
  try {
    await SwaggerParser.validate(structuredClone(document));
  } catch (error) {
    problems.push(`swagger-parser: ${error.message}`);
  }
  try {
    const ajv = schemaValidator();
    for (const name of Object.keys(document.components.schemas)) ajv.getSchema(`schemas#/$defs/${name}`);
  } catch (error) {
    problems.push(`ajv: ${error.message}`);
  }
} else {
  const ajv = schemaValidator();
  const templates = Object.keys(document.paths).map((template) => ({
    template,
    pattern: new RegExp(`^${template.replace(/\{[^}]+\}/g, '[^/]+')}$`),
  }));
  const resolve = (object) => {
    while (object && object.$ref) {
      const parts = object.$ref.replace('#/', '').split('/');
      object = parts.reduce((node, key) => node[key], document);
    }
    return object;
  };
  const lines = (await readFile(exchangesPath, 'utf8')).split('\n').filter((line) => line.trim() !== '');
  for (const line of lines) {
    const { method, path, status, body } = JSON.parse(line);
    const where = `${method.toUpperCase()} ${path} ${status}`;
    const match = templates.find(({ pattern }) => pattern.test(path));
    // A 405 answers a method the path does not have: its body is documented on the path's other operations.
    const operations = match ? document.paths[match.template] : {};
    // A path no template matches is answered 404 with the document's NotFound response.
    const unknownPath = !match && status === 404 ? { responses: { 404: document.components.responses.NotFound } } : undefined;
    const operation =
      operations[method.toLowerCase()] ??
      (status === 405 ? Object.values(operations).find((op) => op.responses?.['405']) : undefined) ??
      unknownPath;
    if (!operation) {
      problems.push(`${where}: no such operation in the document`);
      continue;
    }
    const response = resolve(operation.responses[String(status)] ?? operation.responses.default);
    const schema = response?.content?.['application/json']?.schema;
    if (!schema) {
      problems.push(`${where}: the document has no JSON response for this status`);
      continue;
    }
    let parsed;
    try {
      parsed = JSON.parse(body);
    } catch (error) {
      problems.push(`${where}: not JSON: ${error.message}`);
      continue;
    }
    const validate = ajv.compile(JSON.parse(JSON.stringify(schema).replaceAll('#/components/schemas/', 'schemas#/$defs/')));
    if (!validate(parsed)) problems.push(`${where}: ${ajv.errorsText(validate.errors)}`);
  }
  console.log(`${lines.length} bodies checked`);
}
for (const problem of problems) console.log(problem);
process.exitCode = problems.length > 0 ? 1 : 0;  // not process.exit(): it would cut stdout short on a pipe
