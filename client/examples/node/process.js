// SPDX-License-Identifier: Apache-2.0
// node process.js [TARGET]: a plate with one spike through ProcessUnary, from the proto alone.
const grpc = require('@grpc/grpc-js'), loader = require('@grpc/proto-loader');
const proto = loader.loadSync(`${__dirname}/../../../proto/scanprep/v1/scanprep.proto`, {defaults: true});
const {ScanPrep} = grpc.loadPackageDefinition(proto).scanprep.v1;
const client = new ScanPrep(process.argv[2] || 'localhost:50051', grpc.credentials.createInsecure());
const xyz = [];  // an 8 x 8 plate, 0.5 mm apart, and one point 5 mm above it
for (let r = 0; r < 8; r++) for (let c = 0; c < 8; c++) xyz.push(c * 0.5, r * 0.5, 0);
xyz.push(1.5, 1.5, 5);
const header = {jobId: 'node-1', unit: 'LENGTH_UNIT_MILLIMETRE', totalPoints: xyz.length / 3,
  scans: [{scanId: 'plate', scanlineSpacing: 0.5, pointSpacing: 0.5, uncertainty: 0.01, viewDirection: {z: -1}}],
  options: {stages: ['outliers']}};
client.processUnary({header, points: {xyz}}, {deadline: Date.now() + 60000}, (error, result) => {
  if (error) { console.error(`refused: ${grpc.status[error.code]}: ${error.details}`); process.exit(1); }
  console.log(`${result.report.pointsReceived} points sent, ${result.report.pointsReturned} returned`);
});
